"""Independent shots for PUBs of different shot counts on a seeded qiskit-aer ``SamplerV2``.

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

import copy
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["run_independent"]


def _seeded_aer(sampler) -> bool:
    try:
        from qiskit_aer.primitives import SamplerV2
    except ImportError:  # pragma: no cover - qiskit-aer is a dependency
        return False
    return isinstance(sampler, SamplerV2) and getattr(sampler, "_seed", None) is not None


def _reseeded(sampler, group: int):
    """A shallow copy of an Aer ``SamplerV2`` with a seed derived from its own and ``group``."""
    out = copy.copy(sampler)
    seed = np.random.SeedSequence([int(sampler._seed) % 2**63, group])
    out._seed = int(seed.generate_state(1, dtype=np.uint32)[0])
    return out


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
    """
    wait = wait if wait is not None else (lambda job: job.result())
    pubs = list(pubs)
    groups: dict = {}
    for i, pub in enumerate(pubs):
        groups.setdefault(pub[2] if len(pub) > 2 else None, []).append(i)
    if len(groups) <= 1:
        return list(wait(sampler.run(pubs)))
    aer = _seeded_aer(sampler)
    jobs = [((_reseeded(sampler, g) if aer and g else sampler).run([pubs[i] for i in idx]), idx)
            for g, idx in enumerate(groups.values())]
    out: list = [None] * len(pubs)
    for job, idx in jobs:
        for i, res in zip(idx, wait(job), strict=True):
            out[i] = res
    return out
