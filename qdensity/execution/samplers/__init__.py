"""qdensity's samplers: every ``BaseSamplerV2`` implementation of the package, and the
reseeding protocol they share.

- :class:`HammingWeightSampler` (:mod:`.hamming`) samples Hamming-weight-preserving circuits
  exactly in their ``C(n, k)``-dimensional subspace.
- :class:`AdaptiveSampler` and :class:`AerSampler` (:mod:`.aer`) run on qiskit-aer's public
  ``SamplerV2``: the first picks Aer's method per PUB, the second runs on one given simulator.
  :func:`target_sampler` (:mod:`.target`) builds either on a hardware target's simulator.
- :class:`ExactNoisySampler` (:mod:`.noisy_exact`) draws shots from the exact noisy
  distribution of a few-qubit circuit (the density matrix through every gate and its error);
  :class:`AdaptiveSampler` routes such PUBs to it.
- :mod:`.reseed` states how a seeded sampler gives an independent copy of itself
  (``with_seed``), which the sampler engine needs to give PUBs of different shot counts
  independent shots, and refuses a seeded sampler without it.

:class:`~qdensity.execution.sampler.SamplerEngine` (:mod:`qdensity.execution.sampler`) runs
plans on any of them. The names below are imported on first use (PEP 562): importing the
Hamming-weight sampler does not import qiskit-aer.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from qdensity._lazy import lazy_exports

__all__ = [
    "HammingWeightSampler",
    "AdaptiveSampler",
    "AerSampler",
    "NoiselessSimulators",
    "ExactNoisySampler",
    "target_sampler",
    "derived_seed",
    "sampler_method",
    "check_reseedable",
    "reseeded",
    "run_independent",
]

#: public name -> the module that defines it, imported on first use (PEP 562)
_EXPORTS: dict[str, str] = {
    "HammingWeightSampler": "qdensity.execution.samplers.hamming",
    "AdaptiveSampler": "qdensity.execution.samplers.aer",
    "AerSampler": "qdensity.execution.samplers.aer",
    "NoiselessSimulators": "qdensity.execution.samplers.aer",
    "derived_seed": "qdensity.execution.samplers.aer",
    "sampler_method": "qdensity.execution.samplers.aer",
    "ExactNoisySampler": "qdensity.execution.samplers.noisy_exact",
    "target_sampler": "qdensity.execution.samplers.target",
    "check_reseedable": "qdensity.execution.samplers.reseed",
    "reseeded": "qdensity.execution.samplers.reseed",
    "run_independent": "qdensity.execution.samplers.reseed",
}

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
    from qdensity.execution.samplers.aer import (
        AdaptiveSampler,
        AerSampler,
        NoiselessSimulators,
        derived_seed,
        sampler_method,
    )
    from qdensity.execution.samplers.hamming import HammingWeightSampler
    from qdensity.execution.samplers.noisy_exact import ExactNoisySampler
    from qdensity.execution.samplers.reseed import check_reseedable, reseeded, run_independent
    from qdensity.execution.samplers.target import target_sampler


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
