"""Chebyshev regression targets (paper Methods eq. 12, Supp. J): noisy samples of
``T_degree(x)`` on ``[-1, 1]``, the data of the data re-uploading experiments."""

from __future__ import annotations

import numpy as np

from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_ROWS,
    Array,
    Interval,
    Seed,
    SeedLike,
    as_rng,
    validates,
)

__all__ = ["chebyshev_dataset", "chebyshev_split", "chebyshev"]


@validates(
    num_samples=Interval(int, 1, MAX_ROWS), degree=Interval(int, 0, 10_000),
    noise_std=Interval(float, 0), seed=Seed(),
)
def chebyshev_dataset(
    num_samples: int,
    degree: int = 4,
    noise_std: float = 0.5,
    seed: SeedLike = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Noisy samples of a Chebyshev polynomial ``h(x) = T_degree(x)`` (Methods, eq. 12).

    ``x`` is drawn uniformly from ``[-1, 1]``; the target is ``T_degree(x) + ε`` with
    ``ε ~ N(0, noise_std^2)`` (the paper uses ``T_4`` and variance 0.25, i.e. ``noise_std =
    0.5``, on the training data; ``noise_std = 0`` gives clean targets for a test set).
    ``T_0 = 1``, ``T_1 = x``, ``T_{k+1} = 2 x T_k - T_{k-1}``.

    Parameters
    ----------
    num_samples : int
        ``N >= 1``.
    degree : int
        Polynomial degree ``>= 0``.
    noise_std : float
        Noise standard deviation ``>= 0``.
    seed : int, numpy.random.Generator or None

    Returns
    -------
    X : numpy.ndarray, shape (N, 1)
        Inputs (one column, the re-uploading circuit's ``x[0]``).
    y : numpy.ndarray, shape (N,)
        Noisy targets.

    Examples
    --------
    >>> X, y = chebyshev_dataset(5, degree=2, noise_std=0.0, seed=0)
    >>> bool(np.allclose(y, 2 * X[:, 0] ** 2 - 1))
    True
    """
    num, deg, sigma = int(num_samples), int(degree), float(noise_std)
    rng = as_rng(seed)
    x = rng.uniform(-1.0, 1.0, size=num)
    y = chebyshev(x, deg) + rng.normal(0.0, sigma, size=num)
    return x[:, None], y


@validates(x=Array(ndim=None, max_size=MAX_DENSE_ENTRIES), degree=Interval(int, 0, 10_000))
def chebyshev(x: np.ndarray, degree: int) -> np.ndarray:
    """``T_degree(x)`` by the recurrence of eq. 12 (``T_0 = 1``, ``T_1 = x``,
    ``T_{k+1} = 2 x T_k - T_{k-1}``).

    Parameters
    ----------
    x : numpy.ndarray, any shape
    degree : int
        ``>= 0``.

    Returns
    -------
    numpy.ndarray, the shape of ``x``

    Examples
    --------
    >>> chebyshev(np.array([0.5]), 3).round(6).tolist()  # 4 x^3 - 3 x
    [-1.0]
    """
    deg = int(degree)
    x = np.asarray(x, dtype=float)
    prev, cur = np.ones_like(x), x.copy()
    if deg == 0:
        return prev
    for _ in range(deg - 1):
        prev, cur = cur, 2 * x * cur - prev
    return cur


@validates(
    degree=Interval(int, 0, 10_000), noise_std=Interval(float, 0),
    num_train=Interval(int, 1, MAX_ROWS), num_test=Interval(int, 2, MAX_ROWS), seed=Seed(),
)
def chebyshev_split(
    degree: int = 4,
    noise_std: float = 0.5,
    *,
    num_train: int = 25,
    num_test: int = 110,
    seed: SeedLike = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The re-uploading experiment's data (Methods "Data reuploading density QNN", Supp. J).

    ``num_train`` noisy training points ``(x, T_degree(x) + eps)``, ``x`` uniform on
    ``[-1, 1]``, ``eps ~ N(0, noise_std^2)``; ``num_test`` clean test points on an even grid of
    ``[-1, 1]`` (a proxy for the underlying function, Supp. J). The paper is not consistent:
    Methods uses ``T_4`` and noise variance 0.25 (``noise_std = 0.5``, the default); Supp. J uses
    ``T_2`` and standard deviation 0.2 (``degree=2, noise_std=0.2``).

    Parameters
    ----------
    degree : int
        Polynomial degree ``>= 0``.
    noise_std : float
        Standard deviation of the training noise, ``>= 0``.
    num_train, num_test : int
        25 and 110 in Supp. J.
    seed : int, numpy.random.Generator or None

    Returns
    -------
    X_train : numpy.ndarray, shape (num_train, 1)
    X_test : numpy.ndarray, shape (num_test, 1)
    y_train : numpy.ndarray, shape (num_train,)
    y_test : numpy.ndarray, shape (num_test,)
        Clean ``T_degree`` on the test grid.

    Examples
    --------
    >>> X_tr, X_te, y_tr, y_te = chebyshev_split(2, 0.2, seed=0)
    >>> X_tr.shape, X_te.shape, float(y_te[0])   # T_2(-1) = 1
    ((25, 1), (110, 1), 1.0)
    """
    X_tr, y_tr = chebyshev_dataset(num_train, degree, noise_std, seed)
    x_te = np.linspace(-1.0, 1.0, int(num_test))
    return X_tr, x_te[:, None], y_tr, chebyshev(x_te, degree)
