"""The Neyman scheduler: a pilot run, then ``n_k ~ alpha_k sigma_k`` (Fig. 1c, Supp. I).

The pilot estimates the per-sub-unitary spreads ``sigma_k``; the rest of the budget follows
Neyman's variance-optimal allocation, and pilot and main phase are combined without bias.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from qdensity.execution.intervals import wilson_standard_error
from qdensity.execution.schedulers._common import (
    _check_budget,
    _check_value_range,
    _draw,
    _means,
    _sample_var,
)
from qdensity.execution.schedulers.allocation import allocate_neyman, allocate_proportional
from qdensity.execution.schedulers.base import ScheduleResult, ShotSource
from qdensity.validation import (
    MAX_SHOTS,
    MAX_SUBUNITARIES,
    Array,
    CallableC,
    Interval,
    Seed,
    SeedLike,
    SequenceOf,
    as_rng,
    check_distribution,
    validates,
)

__all__ = ["NeymanScheduler", "neyman"]


@validates(
    pilot_fraction=Interval(float, 0, 1, closed='neither'),
    value_range=SequenceOf(Interval(float), min_len=2, max_len=2), prior_weight=Interval(float, 0),
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
    simulator seed for each call from the generator it is given). A source that takes a
    ``phase`` keyword is told which call is which (``phase="pilot"``, then ``phase="main"``),
    so it can label the pilot's shots apart from the allocation's:
    :meth:`~qdensity.models.DensityQNN.sample` writes them to the ledger as ``pilot_k{k}``
    next to ``randomised_k{k}``, whose shots add up to ``allocation``.

    Parameters
    ----------
    pilot_fraction : float
        Share of the budget spent on the pilot, in (0, 1).
    value_range : (float, float)
        Interval every per-shot value lies in; ``(-1, 1)`` for Pauli observables.
    prior_weight : float
        Pseudo-shots ``c >= 0`` of maximal variance added to each pilot variance for the
        allocation (not for the reported error).

    Examples
    --------
    Sub-unitary 0 always gives ``+1``, sub-unitary 1 a fair ``+-1``: after a pilot of 20% of
    the budget, the main phase gives most shots to the spread-out one:

    >>> from qdensity.execution.schedulers import NeymanScheduler, discrete_source
    >>> src = discrete_source([[1.0, 0.0], [0.5, 0.5]], [1.0, -1.0])
    >>> res = NeymanScheduler(pilot_fraction=0.2).run([0.5, 0.5], 400, src, seed=0)
    >>> res.pilot_allocation.tolist(), res.shots_used, bool(res.allocation[1] > res.allocation[0])
    ([40, 40], 400, True)
    """

    pilot_fraction: float = 0.2
    value_range: tuple[float, float] = (-1.0, 1.0)
    prior_weight: float = 1.0
    name: str = field(default="neyman", init=False)

    def __post_init__(self):
        _check_value_range(self.value_range)

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
        pilot = _draw(source, pilot_alloc, rng, vr, phase="pilot")
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
        main = _draw(source, main_alloc, rng, vr, phase="main")

        both = [np.concatenate([p, q]) for p, q in zip(pilot, main, strict=True)]
        var = np.nan_to_num(_sample_var(both))  # every positive stratum has >= 3 shots
        f_pilot = float(alpha[pos] @ _means(pilot)[pos])
        f_main = float(alpha[pos] @ _means(main)[pos])
        width = vr[1] - vr[0]
        v_pilot = float(np.sum(
            alpha[pos] ** 2 * wilson_standard_error(var[pos], pilot_alloc[pos], width) ** 2))
        v_main = float(np.sum(
            alpha[pos] ** 2 * wilson_standard_error(var[pos], main_alloc[pos], width) ** 2))
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


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), budget=Interval(int, 1, MAX_SHOTS),
    source=CallableC('a callable source(shots_per_k, rng) -> K value arrays'), seed=Seed(),
    pilot_fraction=Interval(float, 0, 1, closed='neither'),
    value_range=SequenceOf(Interval(float), min_len=2, max_len=2), prior_weight=Interval(float, 0),
)
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
    >>> from qdensity.execution.schedulers import discrete_source
    >>> src = discrete_source([[0.5, 0.5], [0.99, 0.01]], [1.0, -1.0])
    >>> res = neyman([0.5, 0.5], 1000, src, seed=3)
    >>> int(res.allocation.sum() + res.pilot_allocation.sum())
    1000
    """
    scheduler = NeymanScheduler(
        pilot_fraction=pilot_fraction, value_range=value_range, prior_weight=prior_weight
    )
    return scheduler.run(alpha, budget, source, seed)
