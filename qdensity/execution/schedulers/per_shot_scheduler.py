"""The per-shot scheduler: the physical protocol of paper Fig. 1c.

Every shot draws its sub-unitary ``k ~ alpha``, so the allocation is ``Multinomial(S, alpha)``
and the estimate of ``f = sum_k alpha_k f_k`` (eq. 3) is the plain mean of all values.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from qdensity.execution.intervals import wilson_standard_error
from qdensity.execution.schedulers._common import _check_value_range, _draw, _means
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
    check_positive_int,
    validates,
)

__all__ = ["PerShotScheduler", "per_shot"]


@validates(value_range=SequenceOf(Interval(float), min_len=2, max_len=2))
@dataclass(frozen=True)
class PerShotScheduler:
    """The physical protocol of Fig. 1c: each shot draws its sub-unitary ``k ~ alpha``.

    The allocation is ``Multinomial(budget, alpha)`` (drawing all shots' ``k`` at once is the
    same distribution as drawing one per shot). The estimate is the mean of all ``budget``
    values, unbiased since every shot's value has mean ``sum_k alpha_k f_k``; its standard error
    is ``std(values, ddof=1) / sqrt(budget)`` in Wilson form (:mod:`qdensity.execution.intervals`:
    never zero, even when every shot gave the same value; with one shot, the bound
    ``(high - low) / 2`` on the standard deviation of a value in ``value_range``).

    Parameters
    ----------
    value_range : (float, float)
        Interval every per-shot value lies in; ``(-1, 1)`` for Pauli observables.

    Examples
    --------
    Every shot gives ``+1``; the estimate is exact, yet its standard error is not zero:

    >>> from qdensity.execution.schedulers import PerShotScheduler, discrete_source
    >>> src = discrete_source([[1.0, 0.0], [1.0, 0.0]], [1.0, -1.0])
    >>> res = PerShotScheduler().run([0.5, 0.5], 100, src, seed=0)
    >>> res.estimate, int(res.allocation.sum()), res.standard_error > 0
    (1.0, 100, True)
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
            se = float(wilson_standard_error(pooled.var(ddof=1), budget, vr[1] - vr[0]))
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


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), budget=Interval(int, 1, MAX_SHOTS),
    source=CallableC('a callable source(shots_per_k, rng) -> K value arrays'), seed=Seed(),
    value_range=SequenceOf(Interval(float), min_len=2, max_len=2),
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
    >>> from qdensity.execution.schedulers import discrete_source
    >>> src = discrete_source([[1.0, 0.0], [0.0, 1.0]], [1.0, -1.0])  # f_0 = 1, f_1 = -1
    >>> res = per_shot([0.75, 0.25], 400, src, seed=1)
    >>> int(res.allocation.sum()), abs(res.estimate - 0.5) < 4 * res.standard_error
    (400, True)
    """
    return PerShotScheduler(value_range=value_range).run(alpha, budget, source, seed)
