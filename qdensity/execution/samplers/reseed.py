"""Reseeding: how a seeded sampler gives an independent copy of itself, and independent shots
for PUBs of different shot counts.

The protocol: a sampler whose ``seed`` is an integer defines ``with_seed(seed)``, returning a
copy of itself that draws from ``seed`` (qdensity's Hamming-weight and Aer samplers do;
qiskit's ``StatevectorSampler`` and qiskit-aer's ``SamplerV2`` are rebuilt from their public
constructors). :func:`reseeded` is the one place that reseeds; :func:`check_reseedable`
refuses, with a ``TypeError``, a seeded sampler of any other class (reseeding it by its class
name would silently give every shot group one seed).


qiskit-aer's ``SamplerV2`` (0.18) groups the PUBs of one ``run`` call by their shot count and
runs every group with the sampler's one ``seed``, so two groups draw from the same random
stream: the outcomes of, say, a 300-shot PUB and a 150-shot PUB of similar distributions are
strongly correlated. A stratified estimate ``sum_k alpha_k mean_k`` over such PUBs (the shot
schedulers of Supp. I, one PUB per sub-unitary with ``n_k`` shots) then has a larger variance
than its standard error says. :func:`run_independent` submits each shot group on its own, the
first with the sampler's seed (a run with one shot count is unchanged), every other one with a
seed derived from it, so runs stay reproducible and groups independent. Other samplers (a
provider's, or Aer's without a seed) get one job per shot count too, all submitted before any
is waited on: qiskit-ibm-runtime (0.48) deprecates PUBs of different shots in one job and
asks for one job per shot count (inside a ``Batch`` to save overhead, which a caller may open
around the engine).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from qdensity.execution.samplers.aer import derived_seed
from qdensity.validation import CallableC, Instance, Interval, SequenceOf, Unchecked, validates

if TYPE_CHECKING:
    from qiskit.primitives import BaseSamplerV2

__all__ = ["reseeded", "check_reseedable", "run_independent"]

#: A sampler: a ``BaseSamplerV2`` or any object with its ``run(pubs, shots=None)``.
_SAMPLER = Unchecked("a BaseSamplerV2, or any object with run(pubs, shots=None) -> job")


def _rebuilt(sampler, seed: int):
    """qiskit's and qiskit-aer's own seeded samplers, rebuilt from their public constructor
    arguments with another seed (they define no ``with_seed``); ``NotImplemented`` for any
    other sampler."""
    from qiskit.primitives import StatevectorSampler

    try:
        from qiskit_aer.primitives import SamplerV2
    except ImportError:  # pragma: no cover - qiskit-aer is a dependency
        SamplerV2 = None
    if SamplerV2 is not None and type(sampler) is SamplerV2:
        opts = sampler.options
        return SamplerV2(default_shots=sampler.default_shots, seed=seed,
                         options={"backend_options": dict(opts.backend_options),
                                  "run_options": dict(opts.run_options)})
    if type(sampler) is StatevectorSampler:
        return StatevectorSampler(default_shots=sampler.default_shots, seed=seed)
    return NotImplemented


def _integer_seed(sampler):
    """The sampler's integer seed, or None (no ``seed``, None, or a Generator drawn in turn:
    successive jobs are independent already)."""
    seed = getattr(sampler, "seed", None)
    if seed is None or isinstance(seed, (np.random.Generator, np.random.RandomState)):
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        return None
    return int(seed)


@validates(sampler=_SAMPLER, name=Instance(str))
def check_reseedable(sampler, name: str = "sampler") -> None:
    """Refuse a seeded sampler that cannot give an independent copy of itself.

    A sampler whose ``seed`` is an integer repeats the same random stream on every ``run``:
    jobs that must be independent (PUBs of different shot counts, successive phases of a
    scheduler) need a copy of it drawing from another seed. Such a sampler must define
    ``with_seed(seed) -> sampler`` (qdensity's own samplers do; qiskit's
    ``StatevectorSampler`` and qiskit-aer's ``SamplerV2`` are rebuilt from their public
    constructors). An unseeded sampler (no ``seed``, None, or a Generator) is accepted as is.

    Parameters
    ----------
    sampler : qiskit.primitives.BaseSamplerV2
    name : str
        The argument's name in the message.

    Raises
    ------
    TypeError
        A sampler with an integer ``seed`` and neither ``with_seed`` nor a known constructor.

    Examples
    --------
    >>> from qiskit.primitives import StatevectorSampler
    >>> from qdensity.execution.samplers import check_reseedable
    >>> check_reseedable(StatevectorSampler(seed=3))  # rebuilt from its constructor
    >>> class Fixed:  # seeded, without with_seed
    ...     seed = 3
    ...     def run(self, pubs, shots=None): ...
    >>> try:
    ...     check_reseedable(Fixed())
    ... except TypeError as err:
    ...     print(str(err).split(":")[0])
    sampler Fixed has an integer seed but no with_seed(seed) method
    """
    if _integer_seed(sampler) is None or callable(getattr(sampler, "with_seed", None)):
        return
    if _rebuilt(sampler, 0) is not NotImplemented:
        return
    raise TypeError(
        f"{name} {type(sampler).__name__} has an integer seed but no with_seed(seed) method: "
        f"qdensity would draw every shot group and every later job from the same random "
        f"stream; define with_seed(seed) returning a copy of the sampler that draws from "
        f"seed, or pass the sampler unseeded")


@validates(sampler=_SAMPLER, seed=Interval(int, 0, None))
def reseeded(sampler, seed: int) -> BaseSamplerV2 | None:
    """A copy of ``sampler`` that draws from ``seed``, or None when it is not seeded.

    Parameters
    ----------
    sampler : qiskit.primitives.BaseSamplerV2
    seed : int
        ``>= 0``.

    Returns
    -------
    BaseSamplerV2 or None
        ``sampler.with_seed(seed)`` (or qiskit's / qiskit-aer's sampler rebuilt with
        ``seed``); None for an unseeded sampler (its jobs draw fresh entropy already).

    Raises
    ------
    TypeError
        As :func:`check_reseedable`.

    Examples
    --------
    >>> from qiskit.primitives import StatevectorSampler
    >>> from qdensity.execution.samplers import reseeded
    >>> copy = reseeded(StatevectorSampler(seed=3, default_shots=100), 7)
    >>> type(copy).__name__, copy.seed, copy.default_shots
    ('StatevectorSampler', 7, 100)
    >>> reseeded(StatevectorSampler(), 7) is None  # unseeded: nothing to reseed
    True
    """
    if _integer_seed(sampler) is None:
        return None
    check_reseedable(sampler)
    with_seed = getattr(sampler, "with_seed", None)
    if callable(with_seed):
        return with_seed(int(seed))
    return _rebuilt(sampler, int(seed))


def _group_sampler(sampler, group: int):
    """The sampler of shot group ``group``: the sampler itself for the first, a copy with a
    seed derived from its own for every other one."""
    base = _integer_seed(sampler)
    if not group or base is None:
        return sampler
    return reseeded(sampler, derived_seed(base, group))


@validates(sampler=_SAMPLER,
           pubs=SequenceOf(Instance(tuple), min_len=0),
           wait=[CallableC('a callable job -> PrimitiveResult'), None])
def run_independent(sampler, pubs: Sequence[tuple], wait: Callable | None = None) -> list:
    """``sampler.run(pubs)``'s PUB results, one job per shot count (independent shots on a
    seeded Aer sampler).

    Parameters
    ----------
    sampler : qiskit.primitives.BaseSamplerV2
    pubs : sequence of (circuit, values, shots) tuples
    wait : callable, optional
        ``wait(job) -> PrimitiveResult``; default ``job.result()``.

    Returns
    -------
    list
        One PUB result per PUB, in the order of ``pubs``.

    Examples
    --------
    Two shot counts, so two jobs (the second from a seed derived from 0):

    >>> from qiskit import QuantumCircuit
    >>> from qiskit.primitives import StatevectorSampler
    >>> from qdensity.execution.samplers import run_independent
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.x(0)
    >>> qc.measure_all()
    >>> results = run_independent(StatevectorSampler(seed=0), [(qc, None, 10), (qc, None, 20)])
    >>> [r.data.meas.get_counts() for r in results]
    [{'1': 10}, {'1': 20}]
    """
    wait = wait if wait is not None else (lambda job: job.result())
    pubs = list(pubs)
    groups: dict = {}
    for i, pub in enumerate(pubs):
        groups.setdefault(pub[2] if len(pub) > 2 else None, []).append(i)
    if len(groups) <= 1:
        return list(wait(sampler.run(pubs)))
    jobs = [(_group_sampler(sampler, g).run([pubs[i] for i in idx]), idx)
            for g, idx in enumerate(groups.values())]
    out: list = [None] * len(pubs)
    for job, idx in jobs:
        for i, res in zip(idx, wait(job), strict=True):
            out[i] = res
    return out
