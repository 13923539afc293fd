"""Shot allocations and the variances they lead to (paper Fig. 1c, Supp. I).

Pure functions, shared by the schedulers: :func:`allocate_proportional` (``n_k ~ alpha_k S``) and
:func:`allocate_neyman` (``n_k ~ alpha_k sigma_k``), both integer and summing to exactly the
budget, and the exact variances of the stratified (:func:`stratified_variance`) and the per-shot
(:func:`per_shot_variance`) estimators of ``f = sum_k alpha_k f_k`` (eq. 3).
"""

from __future__ import annotations

import numpy as np

from qdensity.execution.schedulers._common import _check_budget, _check_shots
from qdensity.validation import (
    MAX_SHOTS,
    MAX_SUBUNITARIES,
    Array,
    Interval,
    check_distribution,
    validates,
)

__all__ = ["allocate_proportional", "allocate_neyman", "stratified_variance", "per_shot_variance"]


def _round_allocation(
    weights: np.ndarray, positive: np.ndarray, budget: int, minimum: int
) -> np.ndarray:
    """Largest-remainder rounding of ``budget * weights / sum(weights)`` with a floor.

    Strata outside ``positive`` get nothing. Strata in ``positive`` below ``minimum`` are topped
    up one shot at a time from the currently largest stratum (ties: larger weight, then lower
    index), so the total stays exactly ``budget``.
    """
    alloc = np.zeros(weights.size, dtype=np.int64)
    w = np.where(positive, weights, 0.0)
    top = float(w.max()) if w.size else 0.0
    if top > 0:
        # scale by the largest weight first: with tiny weights (1e-308) budget / sum overflows
        w = w / top
    total = float(w.sum())
    if total > 0:
        quota = w / total * budget
        alloc = np.floor(quota).astype(np.int64)
        remainder = budget - int(alloc.sum())
        frac = np.where(positive, quota - alloc, -1.0)
        # Largest fractional parts first; stable sort keeps the lower index on ties.
        order = np.argsort(-frac, kind="stable")
        idx = order[: max(remainder, 0)]
        alloc[idx] += 1
    else:  # no weight anywhere: spread evenly over the positive strata
        pos = np.flatnonzero(positive)
        alloc[pos] = budget // pos.size
        alloc[pos[: budget % pos.size]] += 1
    # Floor: take from the largest strata until every positive stratum has `minimum`.
    tie = np.lexsort((np.arange(weights.size)[::-1], w))  # ascending weight, then lower index last
    rank = np.empty(weights.size, dtype=np.int64)
    rank[tie] = np.arange(weights.size)
    for k in np.flatnonzero(positive & (alloc < minimum)):
        while alloc[k] < minimum:
            donors = positive & (alloc > minimum)
            cand = np.flatnonzero(donors)
            top = cand[np.lexsort((rank[cand], alloc[cand]))[-1]]
            alloc[top] -= 1
            alloc[k] += 1
    return alloc


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), budget=Interval(int, 1, MAX_SHOTS),
    minimum=Interval(int, 1, MAX_SHOTS),
)
def allocate_proportional(alpha, budget: int, *, minimum: int = 1) -> np.ndarray:
    """Integer shots ``n_k ~ alpha_k * budget`` summing to exactly ``budget``.

    Largest-remainder rounding of ``alpha_k * budget``; then every sub-unitary with
    ``alpha_k > 0`` is raised to ``minimum`` shots by taking shots from the largest strata.
    Sub-unitaries with ``alpha_k = 0`` get none.

    Parameters
    ----------
    alpha : array_like, shape (K,)
        Mixture distribution of the density QNN (eq. 1); non-negative, sums to 1.
    budget : int
        Total shots ``S``; at least ``minimum`` times the number of positive ``alpha_k``.
    minimum : int
        Least shots for each sub-unitary with ``alpha_k > 0``.

    Returns
    -------
    numpy.ndarray, shape (K,), int64
        ``sum == budget``.

    Examples
    --------
    >>> allocate_proportional([0.5, 0.3, 0.2], 10).tolist()
    [5, 3, 2]
    >>> allocate_proportional([0.98, 0.01, 0.01, 0.0], 10).tolist()
    [8, 1, 1, 0]
    """
    alpha = check_distribution(alpha, "alpha")
    minimum = int(minimum)
    positive = alpha > 0
    m = int(positive.sum())
    budget = _check_budget(
        budget, minimum * m, f"{minimum} shot(s) for each of the {m} sub-unitaries with alpha_k > 0"
    )
    return _round_allocation(alpha, positive, budget, minimum)


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), sigma=Array(ndim=1, max_size=MAX_SUBUNITARIES),
    budget=Interval(int, 1, MAX_SHOTS), minimum=Interval(int, 1, MAX_SHOTS),
)
def allocate_neyman(alpha, sigma, budget: int, *, minimum: int = 1) -> np.ndarray:
    """Neyman allocation ``n_k ~ alpha_k sigma_k``, integer, summing to exactly ``budget``.

    Minimises ``sum_k alpha_k^2 sigma_k^2 / n_k`` (the variance of the stratified estimator)
    over allocations with ``sum_k n_k = budget``. Rounded by largest remainder; every
    sub-unitary with ``alpha_k > 0`` gets at least ``minimum`` shots (also when its
    ``sigma_k = 0``: a spread estimated as zero may not be zero, and the estimator needs a
    shot from every sub-unitary to stay unbiased). If ``alpha_k sigma_k = 0`` for all ``k``,
    every allocation has zero variance and the proportional one is returned.

    Parameters
    ----------
    alpha : array_like, shape (K,)
        Mixture distribution; non-negative, sums to 1.
    sigma : array_like, shape (K,)
        Standard deviation of the per-shot value of each sub-unitary; finite, non-negative.
    budget : int
        Total shots; at least ``minimum`` times the number of positive ``alpha_k``.
    minimum : int
        Least shots for each sub-unitary with ``alpha_k > 0``.

    Returns
    -------
    numpy.ndarray, shape (K,), int64
        ``sum == budget``.

    Examples
    --------
    >>> allocate_neyman([0.5, 0.5], [1.0, 0.25], 100).tolist()
    [80, 20]
    """
    alpha = check_distribution(alpha, "alpha")
    sigma = np.asarray(sigma, dtype=float)
    if sigma.shape != alpha.shape:
        raise ValueError(
            f"sigma must have the shape of alpha {alpha.shape}, got shape {sigma.shape}"
        )
    if np.any(sigma < 0):
        raise ValueError(f"sigma must be non-negative (standard deviations), got {sigma}")
    minimum = int(minimum)
    positive = alpha > 0
    m = int(positive.sum())
    budget = _check_budget(
        budget, minimum * m, f"{minimum} shot(s) for each of the {m} sub-unitaries with alpha_k > 0"
    )
    weights = alpha * sigma
    if not np.any(weights[positive] > 0):
        return _round_allocation(alpha, positive, budget, minimum)
    return _round_allocation(weights, positive, budget, minimum)


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES),
    variances=Array(ndim=1, max_size=MAX_SUBUNITARIES),
    allocation=Array(ndim=1, max_size=MAX_SUBUNITARIES),
)
def stratified_variance(alpha, variances, allocation) -> float:
    """Variance of the stratified estimator ``sum_k alpha_k mean_k``: ``sum alpha_k^2 v_k / n_k``.

    Parameters
    ----------
    alpha : array_like, shape (K,)
    variances : array_like, shape (K,)
        Per-shot variance of each sub-unitary's value.
    allocation : array_like of int, shape (K,)
        Shots per sub-unitary; must be positive wherever ``alpha_k > 0``.

    Returns
    -------
    float

    Examples
    --------
    Spreads ``sigma = (1, 1/4)``: Neyman's allocation reaches ``(sum_k alpha_k sigma_k)^2 / S
    = 0.625^2 / 100``, below the proportional allocation's ``sum_k alpha_k sigma_k^2 / S``:

    >>> from qdensity.execution.schedulers import allocate_neyman, stratified_variance
    >>> alpha, variances = [0.5, 0.5], [1.0, 0.0625]
    >>> stratified_variance(alpha, variances, [50, 50])
    0.0053125
    >>> stratified_variance(alpha, variances, allocate_neyman(alpha, [1.0, 0.25], 100))
    0.00390625
    """
    alpha = check_distribution(alpha, "alpha")
    var = np.asarray(variances, dtype=float)
    n = _check_shots(allocation, alpha.size, "allocation")
    if var.shape != alpha.shape:
        raise ValueError(f"variances must have shape {alpha.shape}, got {var.shape}")
    pos = alpha > 0
    if np.any(n[pos] == 0):
        raise ValueError(
            f"allocation must give a shot to every sub-unitary with alpha_k > 0, got {n}"
        )
    return float(np.sum(alpha[pos] ** 2 * var[pos] / n[pos]))


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), means=Array(ndim=1, max_size=MAX_SUBUNITARIES),
    variances=Array(ndim=1, max_size=MAX_SUBUNITARIES), budget=Interval(int, 1, MAX_SHOTS),
)
def per_shot_variance(alpha, means, variances, budget: int) -> float:
    """Variance of the per-shot protocol's estimate (mean of ``budget`` i.i.d. shots).

    A shot's value has variance ``sum_k alpha_k (v_k + f_k^2) - f^2``
    ``= sum_k alpha_k v_k + sum_k alpha_k (f_k - f)^2``; the second term is what
    stratification removes.

    Parameters
    ----------
    alpha, means, variances : array_like, shape (K,)
    budget : int

    Returns
    -------
    float

    Examples
    --------
    Two deterministic sub-unitaries (``f_k = +-1``, no variance within either): stratifying
    removes all the variance, per-shot sampling keeps ``sum_k alpha_k (f_k - f)^2 / S``:

    >>> from qdensity.execution.schedulers import per_shot_variance, stratified_variance
    >>> per_shot_variance([0.5, 0.5], [1.0, -1.0], [0.0, 0.0], 100)
    0.01
    >>> stratified_variance([0.5, 0.5], [0.0, 0.0], [50, 50])
    0.0
    """
    alpha = check_distribution(alpha, "alpha")
    mu, var = np.asarray(means, dtype=float), np.asarray(variances, dtype=float)
    budget = int(budget)
    if mu.shape != alpha.shape or var.shape != alpha.shape:
        raise ValueError(
            f"means and variances must have shape {alpha.shape}, got {mu.shape}, {var.shape}"
        )
    f = float(alpha @ mu)
    return float((alpha @ var + alpha @ (mu - f) ** 2) / budget)
