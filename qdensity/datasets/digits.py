"""Handwritten digits (scikit-learn's bundled 8x8 copy, no download) reduced by PCA to one
feature per qubit, the stand-in for the paper's MNIST experiments (Numerical results)."""

from __future__ import annotations

import numpy as np

from qdensity.validation import Interval, Seed, seed_u32, validates

__all__ = ["load_digits_features"]


@validates(
    num_features=Interval(int, 1, 64), test_size=Interval(int, 1, 1796), seed=Seed(2**32 - 1),
)
def load_digits_features(
    num_features: int = 8, test_size: int = 300, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Digits (scikit-learn's bundled copy, 1797 images of 8x8) reduced to ``num_features`` by PCA.

    The split is stratified by class; the PCA is fitted on the training split only, so no
    information from the test images leaks into the features.

    Parameters
    ----------
    num_features : int
        Principal components kept, one per qubit of a unary-loaded model (the paper's MNIST
        models use 8 or 10).
    test_size : int
        Images held out for testing.
    seed : int
        Seed of the split and of the PCA solver.

    Returns
    -------
    X_train : numpy.ndarray, shape (1797 - test_size, num_features)
    X_test : numpy.ndarray, shape (test_size, num_features)
    y_train, y_test : numpy.ndarray of int, labels 0..9

    Examples
    --------
    >>> X_tr, X_te, y_tr, y_te = load_digits_features(4, test_size=100)
    >>> X_tr.shape, X_te.shape
    ((1697, 4), (100, 4))
    """
    from sklearn.datasets import load_digits
    from sklearn.decomposition import PCA
    from sklearn.model_selection import train_test_split

    random_state = seed_u32(seed)
    X, y = load_digits(return_X_y=True)
    X_tr, X_te, y_tr, y_te = train_test_split(X, y, test_size=test_size, random_state=random_state,
                                              stratify=y)
    pca = PCA(num_features, random_state=random_state).fit(X_tr)
    return pca.transform(X_tr), pca.transform(X_te), y_tr, y_te
