"""qdensity's own ``BaseSamplerV2`` implementations and the reseeding protocol they share.

:class:`HammingWeightSampler` (:mod:`.hamming`) samples Hamming-weight-preserving circuits
exactly in their ``C(n, k)``-dimensional subspace; :mod:`.reseed` states how a seeded sampler
gives an independent copy of itself (``with_seed``), which the sampler engine needs to give
PUBs of different shot counts independent shots, and refuses a seeded sampler without it.

qdensity's Aer samplers (:class:`~qdensity.hardware.aer_samplers.AdaptiveSampler`,
:class:`~qdensity.hardware.aer_samplers.AerSampler`) are built by a hardware target
(``HardwareTarget.sampler``), one layer below this package, and so live with the targets;
they follow the same protocol. :class:`~qdensity.execution.sampler.SamplerEngine`
(:mod:`qdensity.execution.sampler`) runs plans on any of them.
"""

from qdensity.execution.samplers.hamming import HammingWeightSampler
from qdensity.execution.samplers.reseed import check_reseedable, reseeded, run_independent

__all__ = ["HammingWeightSampler", "check_reseedable", "reseeded", "run_independent"]
