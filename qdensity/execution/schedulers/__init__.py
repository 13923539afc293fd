"""Shot-budget schedulers for the randomised density QNN (paper Fig. 1c, Supp. I).

The randomised density QNN prepares ``rho = sum_k alpha_k U_k rho(x) U_k^dagger`` (eq. 1) only on
average: every shot runs one sub-unitary ``U_k``. Its output (eq. 3)

    f = Tr(O rho) = sum_k alpha_k f_k,    f_k = E[value | sub-unitary k],

is estimated from per-shot values (for a diagonal observable, the eigenvalue of the measured
bitstring). A *scheduler* decides how a budget of ``S`` shots is split over the ``K``
sub-unitaries and how the per-shot values are combined:

* :func:`per_shot` -- the physical protocol of Fig. 1c: every shot draws ``k ~ alpha``, so the
  allocation is ``Multinomial(S, alpha)`` and the estimate is the plain mean of all values.
* :func:`proportional` -- stratified sampling: ``n_k ~ alpha_k S`` fixed in advance. It removes
  the between-sub-unitary part of the per-shot variance, ``sum_k alpha_k (f_k - f)^2 / S``.
* :func:`neyman` -- a pilot run estimates the per-sub-unitary spreads ``sigma_k``; the rest of the
  budget goes ``n_k ~ alpha_k sigma_k`` (Neyman's variance-optimal allocation).

Schedulers never produce shots themselves. They call a *shot source*

    source(shots_per_k, rng) -> list of K arrays, array k of shape (shots_per_k[k],)

so the same scheduler runs on a synthetic distribution (:func:`discrete_source`), on qiskit-aer,
or on hardware through any ``BaseSamplerV2`` (:func:`sampler_source`). Every call is checked:
the number of arrays, their lengths and their range. Allocations are integers that sum to exactly
the budget, so a scheduler never spends more shots than it is given.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BaseSamplerV2

from qdensity.validation import (
    SeedLike,
    as_rng,
    check_circuit,
    check_distribution,
    check_parameter_values,
    check_positive_int,
    check_real_vector,
    seed_int,
)

__all__ = [
    "ScheduleResult",
    "ShotSource",
    "Scheduler",
    "PerShotScheduler",
    "ProportionalScheduler",
    "NeymanScheduler",
    "per_shot",
    "proportional",
    "neyman",
    "allocate_proportional",
    "allocate_neyman",
    "stratified_variance",
    "per_shot_variance",
    "discrete_source",
    "sampler_source",
]

ShotSource = Callable[..., Sequence[np.ndarray]]
"""``source(shots_per_k: ndarray[int] (K,), rng: Generator | None) -> list of K value arrays``."""

_MAX_CLBITS = 63  # outcomes are packed into int64


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ScheduleResult:
    """What a scheduler spent and what it estimated.

    Attributes
    ----------
    name : str
        Scheduler name: ``"per_shot"``, ``"proportional"`` or ``"neyman"``.
    estimate : float
        Estimate of ``f = sum_k alpha_k f_k`` (eq. 3).
    standard_error : float
        Estimated standard deviation of ``estimate``.
    allocation : numpy.ndarray, shape (K,), int64
        Shots run on each sub-unitary in the main phase (the only phase, except for Neyman).
    per_subunitary : numpy.ndarray, shape (K,), float
        Sample mean of the values of each sub-unitary over all shots it received (pilot
        included); ``NaN`` where it received none.
    shots_used : int
        Total shots requested from the source, pilot included; never more than the budget.
    pilot_allocation : numpy.ndarray, shape (K,), int64, or None
        Shots of the pilot phase (Neyman only).
    info : dict
        Scheduler-specific details (e.g. the pilot-estimated spreads and whether Neyman fell
        back to proportional allocation).
    """

    name: str
    estimate: float
    standard_error: float
    allocation: np.ndarray
    per_subunitary: np.ndarray
    shots_used: int
    pilot_allocation: np.ndarray | None = None
    info: dict = field(default_factory=dict)


class Scheduler(Protocol):
    """Anything with ``run(alpha, budget, source, seed) -> ScheduleResult``."""

    name: str

    def run(
        self, alpha, budget: int, source: ShotSource, seed: SeedLike = None
    ) -> ScheduleResult: ...


# --------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------


def _check_value_range(value_range) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value_range)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"value_range must be a pair (low, high) of real numbers, got {value_range!r}"
        ) from exc
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(
            f"value_range must be finite with low < high (the range every per-shot value lies "
            f"in, e.g. (-1, 1) for a Pauli observable), got {value_range!r}"
        )
    return lo, hi


def _check_budget(budget, needed: int, why: str) -> int:
    budget = check_positive_int(budget, "budget")
    if budget < needed:
        raise ValueError(f"budget must be >= {needed} ({why}), got {budget}")
    return budget


def _check_shots(shots, num: int, name: str = "shots_per_k") -> np.ndarray:
    arr = np.asarray(shots)
    if arr.shape != (num,):
        raise ValueError(
            f"{name} must have shape ({num},) (one entry per sub-unitary), got {arr.shape}"
        )
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        if not (np.issubdtype(arr.dtype, np.floating) and np.all(arr == np.round(arr))):
            raise TypeError(f"{name} must hold integers, got {shots!r}")
    arr = arr.astype(np.int64)
    if np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative, got {arr}")
    return arr


def _draw(
    source: ShotSource,
    shots: np.ndarray,
    rng: np.random.Generator,
    value_range: tuple[float, float],
) -> list[np.ndarray]:
    """Call ``source`` and check what comes back (count, lengths, finiteness, range)."""
    out = source(shots.copy(), rng)
    try:
        out = list(out)
    except TypeError as exc:
        raise ValueError(
            f"source must return a sequence of {shots.size} value arrays, got {type(out).__name__}"
        ) from exc
    if len(out) != shots.size:
        raise ValueError(
            f"source returned {len(out)} value arrays, expected {shots.size} (one per sub-unitary)"
        )
    lo, hi = value_range
    checked = []
    for k, (vals, n) in enumerate(zip(out, shots, strict=True)):
        arr = np.asarray(vals, dtype=float)
        if arr.shape != (n,):
            raise ValueError(
                f"source returned values of shape {arr.shape} for sub-unitary {k}, "
                f"which was asked for {n} shots (expected shape ({n},))"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"source returned non-finite values for sub-unitary {k}")
        if arr.size and (arr.min() < lo or arr.max() > hi):
            raise ValueError(
                f"source returned values in [{arr.min()}, {arr.max()}] for sub-unitary {k}, "
                f"outside value_range ({lo}, {hi}); pass the observable's true value_range"
            )
        checked.append(arr)
    return checked


# --------------------------------------------------------------------------------------------
# Allocations (pure functions)
# --------------------------------------------------------------------------------------------


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
    total = float(w.sum())
    if total > 0:
        quota = w * (budget / total)
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
    minimum = check_positive_int(minimum, "minimum")
    positive = alpha > 0
    m = int(positive.sum())
    budget = _check_budget(
        budget, minimum * m, f"{minimum} shot(s) for each of the {m} sub-unitaries with alpha_k > 0"
    )
    return _round_allocation(alpha, positive, budget, minimum)


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
    sigma = check_real_vector(sigma, "sigma")
    if sigma.shape != alpha.shape:
        raise ValueError(
            f"sigma must have the shape of alpha {alpha.shape}, got shape {sigma.shape}"
        )
    if np.any(sigma < 0):
        raise ValueError(f"sigma must be non-negative (standard deviations), got {sigma}")
    minimum = check_positive_int(minimum, "minimum")
    positive = alpha > 0
    m = int(positive.sum())
    budget = _check_budget(
        budget, minimum * m, f"{minimum} shot(s) for each of the {m} sub-unitaries with alpha_k > 0"
    )
    weights = alpha * sigma
    if not np.any(weights[positive] > 0):
        return _round_allocation(alpha, positive, budget, minimum)
    return _round_allocation(weights, positive, budget, minimum)


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
    """
    alpha = check_distribution(alpha, "alpha")
    var = check_real_vector(variances, "variances")
    n = _check_shots(allocation, alpha.size, "allocation")
    if var.shape != alpha.shape:
        raise ValueError(f"variances must have shape {alpha.shape}, got {var.shape}")
    pos = alpha > 0
    if np.any(n[pos] == 0):
        raise ValueError(
            f"allocation must give a shot to every sub-unitary with alpha_k > 0, got {n}"
        )
    return float(np.sum(alpha[pos] ** 2 * var[pos] / n[pos]))


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
    """
    alpha = check_distribution(alpha, "alpha")
    mu = check_real_vector(means, "means")
    var = check_real_vector(variances, "variances")
    budget = check_positive_int(budget, "budget")
    if mu.shape != alpha.shape or var.shape != alpha.shape:
        raise ValueError(
            f"means and variances must have shape {alpha.shape}, got {mu.shape}, {var.shape}"
        )
    f = float(alpha @ mu)
    return float((alpha @ var + alpha @ (mu - f) ** 2) / budget)


# --------------------------------------------------------------------------------------------
# Schedulers
# --------------------------------------------------------------------------------------------


def _means(values: list[np.ndarray]) -> np.ndarray:
    return np.array([v.mean() if v.size else np.nan for v in values])


def _sample_var(values: list[np.ndarray]) -> np.ndarray:
    """Unbiased sample variance per stratum (``NaN`` with fewer than two values)."""
    return np.array([v.var(ddof=1) if v.size >= 2 else np.nan for v in values])


@dataclass(frozen=True)
class PerShotScheduler:
    """The physical protocol of Fig. 1c: each shot draws its sub-unitary ``k ~ alpha``.

    The allocation is ``Multinomial(budget, alpha)`` (drawing all shots' ``k`` at once is the
    same distribution as drawing one per shot). The estimate is the mean of all ``budget``
    values, unbiased since every shot's value has mean ``sum_k alpha_k f_k``; its standard error
    is ``std(values, ddof=1) / sqrt(budget)`` (with one shot, the bound
    ``(high - low) / 2`` on the standard deviation of a value in ``value_range``).

    Parameters
    ----------
    value_range : (float, float)
        Interval every per-shot value lies in; ``(-1, 1)`` for Pauli observables.
    """

    value_range: tuple[float, float] = (-1.0, 1.0)
    name: str = field(default="per_shot", init=False)

    def __post_init__(self):
        _check_value_range(self.value_range)

    def run(self, alpha, budget: int, source: ShotSource, seed: SeedLike = None) -> ScheduleResult:
        """Spend ``budget`` shots; see the class docstring."""
        alpha = check_distribution(alpha, "alpha")
        budget = check_positive_int(budget, "budget")
        vr = _check_value_range(self.value_range)
        rng = as_rng(seed)
        # alpha is on the simplex within 1e-9; numpy's multinomial wants an exact sum.
        counts = rng.multinomial(budget, alpha / alpha.sum()).astype(np.int64)
        values = _draw(source, counts, rng, vr)
        pooled = np.concatenate(values)
        if budget >= 2:
            se = float(pooled.std(ddof=1) / math.sqrt(budget))
        else:
            se = (vr[1] - vr[0]) / 2.0
        return ScheduleResult(
            name=self.name,
            estimate=float(pooled.mean()),
            standard_error=se,
            allocation=counts,
            per_subunitary=_means(values),
            shots_used=int(counts.sum()),
        )


@dataclass(frozen=True)
class ProportionalScheduler:
    """Stratified sampling with proportional allocation.

    ``n_k = allocate_proportional(alpha, budget)`` (exact sum, one shot at least for every
    ``alpha_k > 0``). Estimate ``sum_k alpha_k mean_k`` -- unbiased, since the allocation is
    fixed before any shot -- with standard error ``sqrt(sum_k alpha_k^2 s_k^2 / n_k)``, ``s_k^2``
    the sample variance of stratum ``k``. A stratum with a single shot has no sample variance;
    it uses ``(high - low)^2 / 4``, the largest variance of a value in ``value_range``
    (Popoviciu), so the reported error errs on the large side.

    Parameters
    ----------
    value_range : (float, float)
        Interval every per-shot value lies in; ``(-1, 1)`` for Pauli observables.
    """

    value_range: tuple[float, float] = (-1.0, 1.0)
    name: str = field(default="proportional", init=False)

    def __post_init__(self):
        _check_value_range(self.value_range)

    def run(self, alpha, budget: int, source: ShotSource, seed: SeedLike = None) -> ScheduleResult:
        """Spend exactly ``budget`` shots; see the class docstring."""
        alpha = check_distribution(alpha, "alpha")
        vr = _check_value_range(self.value_range)
        alloc = allocate_proportional(alpha, budget)
        rng = as_rng(seed)
        values = _draw(source, alloc, rng, vr)
        means = _means(values)
        var = _sample_var(values)
        var = np.where(np.isnan(var), (vr[1] - vr[0]) ** 2 / 4.0, var)
        pos = alpha > 0
        return ScheduleResult(
            name=self.name,
            estimate=float(alpha[pos] @ means[pos]),
            standard_error=float(np.sqrt(np.sum(alpha[pos] ** 2 * var[pos] / alloc[pos]))),
            allocation=alloc,
            per_subunitary=means,
            shots_used=int(alloc.sum()),
        )


@dataclass(frozen=True)
class NeymanScheduler:
    """Two-phase stratified sampling: a pilot, then Neyman allocation ``n_k ~ alpha_k sigma_k``.

    1. Pilot: ``P = min(max(round(pilot_fraction * budget), 2 m), budget - m)`` shots, ``m``
       the number of positive ``alpha_k``, allocated proportionally with at least 2 shots per
       positive stratum. Pilot shots count against the budget.
    2. Spreads for the allocation: ``sigma_k^2 = (SS_k + c (high - low)^2 / 4) / (p_k - 1 + c)``,
       the pilot's sample variance shrunk by ``c = prior_weight`` pseudo-shots towards the largest
       variance a bounded value can have. Without it, a stratum whose few pilot shots happened to
       agree would be given a single main shot whatever its true spread; ``prior_weight=0``
       gives the plain pilot variances. If every pilot variance is ~0, the main phase uses the
       proportional allocation instead (``info["fallback"] = True``).
    3. Main: the remaining ``M = budget - P`` shots with ``allocate_neyman`` (one shot at least
       per positive stratum).

    Estimator (unbiased). ``F_pilot = sum_k alpha_k pbar_k`` is unbiased (fixed allocation).
    ``F_main = sum_k alpha_k mbar_k`` uses only main-phase shots; given the pilot, the main
    allocation is fixed and fresh shots are independent of the pilot, so
    ``E[F_main | pilot] = f`` and hence ``E[F_main] = f`` and ``Cov(F_pilot, F_main) = 0``. The
    reported estimate is ``lambda F_pilot + (1 - lambda) F_main`` with the data-independent
    weight ``lambda = P / budget``, which is unbiased too; its variance
    ``lambda^2 Var F_pilot + (1 - lambda)^2 Var F_main`` interpolates between the proportional
    and the Neyman variance, so the pilot shots are not wasted. (Pooling pilot and main shots
    per stratum would not be unbiased: the pooling weights ``p_k / (p_k + n_k)`` depend on the
    pilot values through ``n_k``.) The standard error plugs in the per-stratum sample variance
    of all that stratum's shots (at least 3, so always defined).

    The source must give independent shots in every call (:func:`sampler_source` draws a fresh
    simulator seed for each call from the generator it is given).

    Parameters
    ----------
    pilot_fraction : float
        Share of the budget spent on the pilot, in (0, 1).
    value_range : (float, float)
        Interval every per-shot value lies in; ``(-1, 1)`` for Pauli observables.
    prior_weight : float
        Pseudo-shots ``c >= 0`` of maximal variance added to each pilot variance for the
        allocation (not for the reported error).
    """

    pilot_fraction: float = 0.2
    value_range: tuple[float, float] = (-1.0, 1.0)
    prior_weight: float = 1.0
    name: str = field(default="neyman", init=False)

    def __post_init__(self):
        _check_value_range(self.value_range)
        pf = self.pilot_fraction
        if isinstance(pf, bool) or not isinstance(pf, numbers.Real) or not 0 < pf < 1:
            raise ValueError(f"pilot_fraction must be a real number in (0, 1), got {pf!r}")
        pw = self.prior_weight
        if (
            isinstance(pw, bool)
            or not isinstance(pw, numbers.Real)
            or not (math.isfinite(pw) and pw >= 0)
        ):
            raise ValueError(f"prior_weight must be a finite real number >= 0, got {pw!r}")

    def run(self, alpha, budget: int, source: ShotSource, seed: SeedLike = None) -> ScheduleResult:
        """Spend exactly ``budget`` shots (pilot included); see the class docstring."""
        alpha = check_distribution(alpha, "alpha")
        vr = _check_value_range(self.value_range)
        pos = alpha > 0
        m = int(pos.sum())
        budget = _check_budget(
            budget,
            3 * m,
            f"2 pilot shots and 1 main shot for each of the {m} sub-unitaries with alpha_k > 0",
        )
        rng = as_rng(seed)
        vmax = (vr[1] - vr[0]) ** 2 / 4.0

        n_pilot = min(max(round(self.pilot_fraction * budget), 2 * m), budget - m)
        pilot_alloc = allocate_proportional(alpha, n_pilot, minimum=2)
        pilot = _draw(source, pilot_alloc, rng, vr)
        pilot_var = _sample_var(pilot)

        n_main = budget - n_pilot
        fallback = not np.any(pilot_var[pos] > 1e-12 * vmax)
        if fallback:
            sigma_alloc = np.zeros(alpha.size)
            main_alloc = allocate_proportional(alpha, n_main)
        else:
            c = float(self.prior_weight)
            ss = np.where(pos, np.nan_to_num(pilot_var) * (pilot_alloc - 1), 0.0)
            denom = np.where(pos, pilot_alloc - 1 + c, 1.0)
            sigma_alloc = np.where(pos, np.sqrt((ss + c * vmax) / denom), 0.0)
            main_alloc = allocate_neyman(alpha, sigma_alloc, n_main)
        main = _draw(source, main_alloc, rng, vr)

        both = [np.concatenate([p, q]) for p, q in zip(pilot, main, strict=True)]
        var = np.nan_to_num(_sample_var(both))  # every positive stratum has >= 3 shots
        f_pilot = float(alpha[pos] @ _means(pilot)[pos])
        f_main = float(alpha[pos] @ _means(main)[pos])
        v_pilot = float(np.sum(alpha[pos] ** 2 * var[pos] / pilot_alloc[pos]))
        v_main = float(np.sum(alpha[pos] ** 2 * var[pos] / main_alloc[pos]))
        lam = n_pilot / budget
        return ScheduleResult(
            name=self.name,
            estimate=lam * f_pilot + (1 - lam) * f_main,
            standard_error=math.sqrt(lam**2 * v_pilot + (1 - lam) ** 2 * v_main),
            allocation=main_alloc,
            per_subunitary=_means(both),
            shots_used=int(pilot_alloc.sum() + main_alloc.sum()),
            pilot_allocation=pilot_alloc,
            info={
                "fallback": fallback,
                "pilot_sigma": np.sqrt(np.nan_to_num(pilot_var)),
                "allocation_sigma": sigma_alloc,
                "pilot_estimate": f_pilot,
                "main_estimate": f_main,
                "pilot_weight": lam,
            },
        )


def per_shot(
    alpha,
    budget: int,
    source: ShotSource,
    seed: SeedLike = None,
    *,
    value_range: tuple[float, float] = (-1.0, 1.0),
) -> ScheduleResult:
    """Estimate ``f = sum_k alpha_k f_k`` the physical way: every shot draws ``k ~ alpha``.

    See :class:`PerShotScheduler`.

    Parameters
    ----------
    alpha : array_like, shape (K,)
        Mixture distribution (eq. 1); non-negative, sums to 1 within 1e-9 (not renormalised).
    budget : int
        Shots ``S >= 1``; exactly ``S`` are requested from ``source``.
    source : callable
        ``source(shots_per_k (K,) int64, rng) -> K arrays of per-shot values``.
    seed : int, numpy.random.Generator or None
        Drives the sub-unitary draws and is passed on to ``source``.
    value_range : (float, float)
        Interval the per-shot values lie in.

    Returns
    -------
    ScheduleResult

    Examples
    --------
    >>> import numpy as np
    >>> src = discrete_source([[1.0, 0.0], [0.0, 1.0]], [1.0, -1.0])  # f_0 = 1, f_1 = -1
    >>> res = per_shot([0.75, 0.25], 400, src, seed=1)
    >>> int(res.allocation.sum()), abs(res.estimate - 0.5) < 4 * res.standard_error
    (400, True)
    """
    return PerShotScheduler(value_range=value_range).run(alpha, budget, source, seed)


def proportional(
    alpha,
    budget: int,
    source: ShotSource,
    seed: SeedLike = None,
    *,
    value_range: tuple[float, float] = (-1.0, 1.0),
) -> ScheduleResult:
    """Estimate ``f = sum_k alpha_k f_k`` with proportional stratified sampling.

    See :class:`ProportionalScheduler`. Parameters as :func:`per_shot`; ``budget`` must be at
    least the number of positive ``alpha_k``.

    Returns
    -------
    ScheduleResult

    Examples
    --------
    >>> src = discrete_source([[1.0, 0.0], [0.0, 1.0]], [1.0, -1.0])
    >>> res = proportional([0.75, 0.25], 400, src, seed=1)
    >>> res.allocation.tolist(), res.estimate, res.standard_error
    ([300, 100], 0.5, 0.0)
    """
    return ProportionalScheduler(value_range=value_range).run(alpha, budget, source, seed)


def neyman(
    alpha,
    budget: int,
    source: ShotSource,
    seed: SeedLike = None,
    pilot_fraction: float = 0.2,
    *,
    value_range: tuple[float, float] = (-1.0, 1.0),
    prior_weight: float = 1.0,
) -> ScheduleResult:
    """Estimate ``f = sum_k alpha_k f_k`` with a pilot run and Neyman allocation.

    See :class:`NeymanScheduler` for the allocation and why the estimator is unbiased.
    ``budget`` must be at least ``3 m`` (2 pilot shots and 1 main shot per positive ``alpha_k``).

    Returns
    -------
    ScheduleResult
        ``allocation`` is the main phase, ``pilot_allocation`` the pilot; together they sum to
        ``budget``.

    Examples
    --------
    >>> src = discrete_source([[0.5, 0.5], [0.99, 0.01]], [1.0, -1.0])
    >>> res = neyman([0.5, 0.5], 1000, src, seed=3)
    >>> int(res.allocation.sum() + res.pilot_allocation.sum())
    1000
    """
    scheduler = NeymanScheduler(
        pilot_fraction=pilot_fraction, value_range=value_range, prior_weight=prior_weight
    )
    return scheduler.run(alpha, budget, source, seed)


# --------------------------------------------------------------------------------------------
# Shot sources
# --------------------------------------------------------------------------------------------


def discrete_source(probabilities, values, seed: SeedLike = None) -> ShotSource:
    """A synthetic shot source: sub-unitary ``k`` yields ``values[j]`` with ``probabilities[k, j]``.

    Typical use: ``probabilities[k]`` are the exact outcome probabilities of circuit ``k``
    (``Statevector.probabilities()``) and ``values[j]`` the observable's eigenvalue on
    bitstring ``j``; then the source samples what a noiseless device would.

    Parameters
    ----------
    probabilities : array_like, shape (K, M)
        Row ``k`` is a distribution over ``M`` outcomes.
    values : array_like, shape (M,) or (K, M)
        Value of each outcome (shared, or per sub-unitary).
    seed : int, numpy.random.Generator or None
        Used only when the source is called with ``rng=None``.

    Returns
    -------
    callable
        ``source(shots_per_k, rng=None) -> list of K arrays``.

    Examples
    --------
    >>> src = discrete_source([[1.0, 0.0], [0.5, 0.5]], [1.0, -1.0])
    >>> [v.shape for v in src([3, 0], None)]
    [(3,), (0,)]
    """
    probs = np.asarray(probabilities, dtype=float)
    if probs.ndim != 2:
        raise ValueError(f"probabilities must have shape (K, M), got shape {probs.shape}")
    for k in range(probs.shape[0]):
        check_distribution(probs[k], f"probabilities[{k}]")
    vals = np.asarray(values, dtype=float)
    if vals.shape == (probs.shape[1],):
        vals = np.broadcast_to(vals, probs.shape)
    if vals.shape != probs.shape or not np.all(np.isfinite(vals)):
        raise ValueError(
            f"values must be finite with shape ({probs.shape[1]},) or {probs.shape}, "
            f"got shape {np.shape(values)}"
        )
    cdf = np.cumsum(probs, axis=1)
    cdf[:, -1] = np.inf  # rows sum to 1 within 1e-9: never index past the last outcome
    own = as_rng(seed)
    num = probs.shape[0]

    def source(shots_per_k, rng: np.random.Generator | None = None) -> list[np.ndarray]:
        shots = _check_shots(shots_per_k, num)
        gen = own if rng is None else rng
        out = []
        for k in range(num):
            idx = np.searchsorted(cdf[k], gen.random(shots[k]), side="right")
            out.append(vals[k, idx])
        return out

    return source


def _outcome_ints(pub_result, circuit: QuantumCircuit) -> np.ndarray:
    """Per-shot outcomes as integers in which bit ``j`` is clbit ``j`` of ``circuit``."""
    data = pub_result.data
    ints = None
    for creg in circuit.cregs:
        bits = getattr(data, creg.name).to_bool_array(order="little")  # (shots, len(creg))
        weights = np.array([1 << circuit.find_bit(b).index for b in creg], dtype=np.int64)
        part = bits.astype(np.int64) @ weights
        ints = part if ints is None else ints | part
    return ints


def sampler_source(
    circuits: Sequence[QuantumCircuit],
    values_fn: Callable[[np.ndarray], np.ndarray],
    sampler: BaseSamplerV2 | None = None,
    seed: SeedLike = None,
    parameter_values: Sequence | None = None,
) -> ShotSource:
    """A shot source that runs the ``K`` sub-unitary circuits through a ``SamplerV2``.

    Each call submits ONE ``sampler.run`` job with one PUB ``(circuit_k, values_k, n_k)`` per
    sub-unitary that is asked for ``n_k > 0`` shots (PUBs with no shots are left out), and turns
    each PUB's bit array into per-shot values: the outcome of every shot, as an integer whose
    bit ``j`` is clbit ``j`` of the circuit, goes through ``values_fn``. So every value comes
    from a shot that was really taken.

    Parameters
    ----------
    circuits : sequence of QuantumCircuit, length K
        Measured circuits, one per sub-unitary (1 to 63 clbits, all in classical registers).
        They must already be in a form the sampler accepts: plain circuits for the default
        Aer sampler, transpiled ones for a hardware primitive.
    values_fn : callable
        ``values_fn(outcomes (shots,) int64) -> values (shots,)``, e.g. the eigenvalue of a
        diagonal observable: ``lambda b: 1.0 - 2.0 * (b & 1)`` for ``Z`` on clbit 0.
    sampler : BaseSamplerV2 or None
        ``None``: a fresh ``qiskit_aer.primitives.SamplerV2`` for each call, seeded from the
        call's generator, so calls are independent and a seed reproduces them. A sampler you
        pass is used as it is; note that an Aer ``SamplerV2`` built with a fixed ``seed``
        returns the same shots on every call, which makes a pilot and a main phase correlated.
    seed : int, numpy.random.Generator or None
        Seeds the default sampler when the source is called with ``rng=None``; schedulers pass
        their own generator, which then governs reproducibility.
    parameter_values : sequence of length K, or None
        ``parameter_values[k]``: values (P_k,) for ``circuits[k].parameters`` (``None`` for a
        circuit without parameters).

    Returns
    -------
    callable
        ``source(shots_per_k (K,) ints, rng=None) -> list of K arrays of per-shot values``.

    Examples
    --------
    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> circuits = []
    >>> for theta in (0.3, 1.2, 2.0):
    ...     qc = QuantumCircuit(1, 1)
    ...     _ = qc.ry(theta, 0)
    ...     _ = qc.measure(0, 0)
    ...     circuits.append(qc)
    >>> src = sampler_source(circuits, lambda b: 1.0 - 2.0 * (b & 1))  # Z eigenvalue
    >>> res = proportional([0.5, 0.3, 0.2], 3000, src, seed=7)
    >>> exact = 0.5 * np.cos(0.3) + 0.3 * np.cos(1.2) + 0.2 * np.cos(2.0)
    >>> bool(abs(res.estimate - exact) < 5 * res.standard_error)
    True
    """
    if isinstance(circuits, QuantumCircuit):
        raise TypeError("circuits must be a sequence of QuantumCircuits (one per sub-unitary)")
    circuits = list(circuits)
    if not circuits:
        raise ValueError("circuits must hold at least one QuantumCircuit, got none")
    for k, qc in enumerate(circuits):
        check_circuit(qc, f"circuits[{k}]")
        if not 1 <= qc.num_clbits <= _MAX_CLBITS:
            raise ValueError(
                f"circuits[{k}] must have 1 to {_MAX_CLBITS} classical bits (measured outcomes), "
                f"got {qc.num_clbits}"
            )
        loose = [b for b in qc.clbits if not qc.find_bit(b).registers]
        if loose:
            raise ValueError(
                f"circuits[{k}] has {len(loose)} classical bits outside any ClassicalRegister; "
                "samplers only return registers"
            )
    if not callable(values_fn):
        raise TypeError(f"values_fn must be callable, got {type(values_fn).__name__}")
    if sampler is not None and not isinstance(sampler, BaseSamplerV2):
        raise TypeError(
            f"sampler must be a qiskit BaseSamplerV2 (e.g. qiskit_aer.primitives.SamplerV2), "
            f"got {type(sampler).__name__}"
        )
    num = len(circuits)
    if parameter_values is None:
        parameter_values = [None] * num
    parameter_values = list(parameter_values)
    if len(parameter_values) != num:
        raise ValueError(
            f"parameter_values must have one entry per circuit ({num}), got {len(parameter_values)}"
        )
    bound = []
    for k, (qc, pv) in enumerate(zip(circuits, parameter_values, strict=True)):
        if pv is None:
            if qc.num_parameters:
                raise ValueError(
                    f"parameter_values[{k}] is None but circuits[{k}] has "
                    f"{qc.num_parameters} parameters"
                )
            bound.append(None)
            continue
        arr = check_parameter_values(pv, qc.num_parameters, f"parameter_values[{k}]")
        if arr.ndim != 1:
            raise ValueError(
                f"parameter_values[{k}] must be one row of shape ({qc.num_parameters},), "
                f"got shape {arr.shape}"
            )
        bound.append(arr)
    own = as_rng(seed)

    def source(shots_per_k, rng: np.random.Generator | None = None) -> list[np.ndarray]:
        shots = _check_shots(shots_per_k, num)
        gen = own if rng is None else rng
        out = [np.zeros(0) for _ in range(num)]
        active = np.flatnonzero(shots > 0)
        if active.size == 0:
            return out
        if sampler is None:
            from qiskit_aer.primitives import SamplerV2

            runner = SamplerV2(seed=seed_int(gen))
        else:
            runner = sampler
        pubs = [(circuits[k], bound[k], int(shots[k])) for k in active]
        result = runner.run(pubs).result()
        if len(result) != len(pubs):
            raise ValueError(f"sampler returned {len(result)} PUB results for {len(pubs)} PUBs")
        for k, pub_result in zip(active, result, strict=True):
            outcomes = _outcome_ints(pub_result, circuits[k])
            if outcomes.shape != (shots[k],):
                raise ValueError(
                    f"sampler returned {outcomes.shape} outcomes for circuits[{k}], "
                    f"asked for {shots[k]} shots"
                )
            vals = np.asarray(values_fn(outcomes), dtype=float)
            if vals.shape != outcomes.shape:
                raise ValueError(
                    f"values_fn must map outcomes of shape {outcomes.shape} to values of the same "
                    f"shape, got {vals.shape}"
                )
            out[k] = vals
        return out

    return source
