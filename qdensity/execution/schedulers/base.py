"""What every scheduler shares: the result type, the scheduler protocol and the shot-source type.

A scheduler (paper Fig. 1c, Supp. I) spends a shot budget on the ``K`` sub-unitaries of the
randomised density QNN through a *shot source* (:data:`ShotSource`) and returns a
:class:`ScheduleResult` with its estimate of ``f = sum_k alpha_k f_k`` (eq. 3).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from qdensity.validation import Array, Instance, Interval, SeedLike, validates

__all__ = ["ScheduleResult", "ShotSource", "Scheduler"]

ShotSource = Callable[..., Sequence[np.ndarray]]
"""``source(shots_per_k: ndarray[int] (K,), rng: Generator | None) -> list of K value arrays``."""


@validates(
    # scalars for an observable, one entry per qubit (n,) for the unary-probability readout
    name=Instance(str), estimate=[Interval(float), Array(ndim=1)],
    standard_error=[Interval(float, 0), Array(ndim=1)],
    allocation=Array(ndim=1, dtype='int', min_size=0),
    per_subunitary=Array(ndim=(1, 2), min_size=0, finite=False), shots_used=Interval(int, 0),
    pilot_allocation=[Array(ndim=1, dtype='int', min_size=0), None], info=Instance(dict),
)
@dataclass(frozen=True)
class ScheduleResult:
    """What a scheduler spent and what it estimated.

    Attributes
    ----------
    name : str
        Scheduler name: ``"per_shot"``, ``"proportional"`` or ``"neyman"``.
    estimate : float, or numpy.ndarray of shape (n,)
        Estimate of ``f = sum_k alpha_k f_k`` (eq. 3); one per qubit for a model that reads
        out unary probabilities.
    standard_error : float, or numpy.ndarray of shape (n,)
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

    Examples
    --------
    >>> from qdensity.execution.schedulers import discrete_source, proportional
    >>> src = discrete_source([[1.0, 0.0], [0.0, 1.0]], [1.0, -1.0])  # f_0 = 1, f_1 = -1
    >>> res = proportional([0.75, 0.25], 8, src, seed=0)
    >>> res.name, res.estimate, res.allocation.tolist(), res.per_subunitary.tolist()
    ('proportional', 0.5, [6, 2], [1.0, -1.0])
    """

    name: str
    estimate: float | np.ndarray
    standard_error: float | np.ndarray
    allocation: np.ndarray
    per_subunitary: np.ndarray
    shots_used: int
    pilot_allocation: np.ndarray | None = None
    info: dict = field(default_factory=dict)


class Scheduler(Protocol):
    """Anything with ``run(alpha, budget, source, seed) -> ScheduleResult``.

    Examples
    --------
    >>> from qdensity.execution.schedulers import (NeymanScheduler, PerShotScheduler,
    ...                                            ProportionalScheduler)
    >>> [s.name for s in (PerShotScheduler(), ProportionalScheduler(), NeymanScheduler())]
    ['per_shot', 'proportional', 'neyman']
    """

    name: str

    def run(
        self, alpha, budget: int, source: ShotSource, seed: SeedLike = None
    ) -> ScheduleResult: ...
