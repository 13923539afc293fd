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

(a source that also takes a ``phase`` keyword is told ``"pilot"`` or ``"main"`` by :func:`neyman`)

so the same scheduler runs on a synthetic distribution (:func:`discrete_source`), on qiskit-aer,
or on hardware through any ``BaseSamplerV2`` (:func:`sampler_source`). Every call is checked:
the number of arrays, their lengths and their range. Allocations are integers that sum to exactly
the budget, so a scheduler never spends more shots than it is given.
"""

from qdensity.execution.schedulers.allocation import (
    allocate_neyman,
    allocate_proportional,
    per_shot_variance,
    stratified_variance,
)
from qdensity.execution.schedulers.base import Scheduler, ScheduleResult, ShotSource
from qdensity.execution.schedulers.neyman_scheduler import NeymanScheduler, neyman
from qdensity.execution.schedulers.per_shot_scheduler import PerShotScheduler, per_shot
from qdensity.execution.schedulers.proportional_scheduler import (
    ProportionalScheduler,
    proportional,
)
from qdensity.execution.schedulers.sources import discrete_source, sampler_source

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
