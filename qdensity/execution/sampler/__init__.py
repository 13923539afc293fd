"""The sampler engine: shots through any ``BaseSamplerV2``, counted on a ledger.

:class:`SamplerEngine` (:mod:`.engine`) runs plans; readout mitigation and Hamming-weight
post-selection are its options (:mod:`._correction`); :mod:`.mitigated` and
:mod:`.postselection` read estimates off corrected and post-selected shots; :mod:`.runtime`
puts the engine on a provider's runtime sampler. The samplers themselves (the Hamming-weight
sampler, which the engine uses wherever it is exact, and the reseeding protocol) are in
:mod:`qdensity.execution.samplers`.
"""

from qdensity.execution.sampler.engine import (
    LedgerEntry,
    SamplerEngine,
    ShotLedger,
    bitarray_to_bits,
    bitarray_to_probabilities,
)

__all__ = [
    "SamplerEngine",
    "ShotLedger",
    "LedgerEntry",
    "bitarray_to_bits",
    "bitarray_to_probabilities",
]
