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

from collections.abc import Callable, Sequence

from qdensity.hardware.aer_samplers import AdaptiveSampler, AerSampler, derived_seed

__all__ = ["run_independent"]


def _reseeded(sampler, group: int):
    """``sampler`` with a seed derived from its own and ``group``, or None when it has none.

    qdensity's Aer samplers (:mod:`qdensity.hardware.aer_samplers`) say so through
    ``with_seed``. qiskit-aer's own ``SamplerV2`` is rebuilt from its public ``seed``,
    ``default_shots`` and ``options`` (the same counts as rewriting its seed would give); one
    built with ``SamplerV2.from_backend`` carries a simulator its public API does not give
    back, so qdensity builds none (``HardwareTarget.sampler`` returns an ``AerSampler``, whose
    simulator is public): wrap such a simulator as ``AerSampler(simulator, seed)``.
    """
    seed = getattr(sampler, "seed", None)
    if isinstance(sampler, (AdaptiveSampler, AerSampler)):
        return None if seed is None else sampler.with_seed(derived_seed(seed, group))
    try:
        from qiskit_aer.primitives import SamplerV2
    except ImportError:  # pragma: no cover - qiskit-aer is a dependency
        return None
    if not isinstance(sampler, SamplerV2) or seed is None:
        return None
    opts = sampler.options
    return SamplerV2(default_shots=sampler.default_shots, seed=derived_seed(seed, group),
                     options={"backend_options": dict(opts.backend_options),
                              "run_options": dict(opts.run_options)})


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
    jobs = [(((g and _reseeded(sampler, g)) or sampler).run([pubs[i] for i in idx]), idx)
            for g, idx in enumerate(groups.values())]
    out: list = [None] * len(pubs)
    for job, idx in jobs:
        for i, res in zip(idx, wait(job), strict=True):
            out[i] = res
    return out
