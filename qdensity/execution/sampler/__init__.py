"""The sampler engine: shots through any ``BaseSamplerV2``, counted on a ledger.

:class:`SamplerEngine` (:mod:`.engine`) runs plans; readout mitigation and Hamming-weight
post-selection are its options (:mod:`._correction`); :mod:`.mitigated` and
:mod:`.postselection` read estimates off corrected and post-selected shots; :mod:`.runtime`
puts the engine on a provider's runtime sampler; :class:`HammingWeightSampler` (:mod:`.hamming`)
samples Hamming-weight-preserving circuits exactly in their subspace, and the engine uses it
wherever that is exact.
"""

from qdensity.execution.sampler.engine import (
    LedgerEntry,
    SamplerEngine,
    ShotLedger,
    bitarray_to_bits,
    bitarray_to_probabilities,
)
from qdensity.execution.sampler.hamming import HammingWeightSampler

__all__ = [
    "SamplerEngine",
    "HammingWeightSampler",
    "ShotLedger",
    "LedgerEntry",
    "bitarray_to_bits",
    "bitarray_to_probabilities",
]
