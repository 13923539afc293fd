"""Chebyshev regression targets (paper Methods eq. 12, Supp. J): noisy samples of
``T_degree(x)`` on ``[-1, 1]``, the data of the data re-uploading experiments."""

from __future__ import annotations

import numpy as np

from qdensity.validation import SeedLike, as_rng, check_nonnegative_float, check_positive_int

__all__ = ["chebyshev_dataset"]


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
    num = check_positive_int(num_samples, "num_samples", minimum=1)
    deg = check_positive_int(degree, "degree", minimum=0)
    sigma = check_nonnegative_float(noise_std, "noise_std")
    rng = as_rng(seed)
    x = rng.uniform(-1.0, 1.0, size=num)
    prev, cur = np.ones_like(x), x.copy()
    if deg == 0:
        cur = prev
    for _ in range(deg - 1):
        prev, cur = cur, 2 * x * cur - prev
    y = cur + rng.normal(0.0, sigma, size=num)
    return x[:, None], y
