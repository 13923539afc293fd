"""The proportional scheduler: stratified sampling with ``n_k ~ alpha_k S`` (Fig. 1c, Supp. I).

The allocation is fixed in advance, which removes the between-sub-unitary part of the per-shot
variance, ``sum_k alpha_k (f_k - f)^2 / S``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from qdensity.execution.intervals import wilson_standard_error
from qdensity.execution.schedulers._common import (
    _check_value_range,
    _draw,
    _means,
    _sample_var,
)
from qdensity.execution.schedulers.allocation import allocate_proportional
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

__all__ = ["ProportionalScheduler", "proportional"]


@validates(value_range=SequenceOf(Interval(float), min_len=2, max_len=2))
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

    Examples
    --------
    One shot per stratum: each stratum's variance is Popoviciu's bound ``(1 - (-1))^2 / 4 = 1``,
    so the standard error is ``sqrt(0.5^2 + 0.5^2)``:

    >>> from qdensity.execution.schedulers import ProportionalScheduler, discrete_source
    >>> src = discrete_source([[1.0, 0.0], [0.5, 0.5]], [1.0, -1.0])
    >>> res = ProportionalScheduler(value_range=(-1.0, 1.0)).run([0.5, 0.5], 2, src, seed=0)
    >>> res.allocation.tolist(), round(res.standard_error, 12) == round(0.5**0.5, 12)
    ([1, 1], True)
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
        pos = alpha > 0
        # single-shot strata: the largest variance a bounded value can have; else the sample
        # variance with the Wilson term, so that agreeing shots do not claim certainty
        se2 = np.where(np.isnan(var), (vr[1] - vr[0]) ** 2 / 4.0 / np.maximum(alloc, 1),
                       wilson_standard_error(np.nan_to_num(var), np.maximum(alloc, 1),
                                             vr[1] - vr[0]) ** 2)
        return ScheduleResult(
            name=self.name,
            estimate=float(alpha[pos] @ means[pos]),
            standard_error=float(np.sqrt(np.sum(alpha[pos] ** 2 * se2[pos]))),
            allocation=alloc,
            per_subunitary=means,
            shots_used=int(alloc.sum()),
        )


@validates(
    alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES), budget=Interval(int, 1, MAX_SHOTS),
    source=CallableC('a callable source(shots_per_k, rng) -> K value arrays'), seed=Seed(),
    value_range=SequenceOf(Interval(float), min_len=2, max_len=2),
)
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
    >>> from qdensity.execution.schedulers import discrete_source
    >>> src = discrete_source([[1.0, 0.0], [0.0, 1.0]], [1.0, -1.0])
    >>> res = proportional([0.75, 0.25], 400, src, seed=1)
    >>> res.allocation.tolist(), res.estimate
    ([300, 100], 0.5)

    Every shot agreed, yet the error is not zero (the Wilson term, ``R / (2 n)`` per stratum):

    >>> round(res.standard_error, 6)
    0.003536
    """
    return ProportionalScheduler(value_range=value_range).run(alpha, budget, source, seed)
