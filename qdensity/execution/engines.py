"""Every engine's class in one place (the module of the first release's import path).

The engines live in their own sub-packages: :class:`~qdensity.execution.exact.ExactEngine`
(exact Aer probabilities), :class:`~qdensity.execution.statevector.AdjointEngine` (a statevector
and its adjoint gradients), :class:`~qdensity.execution.sampler.SamplerEngine` (shots through
any ``BaseSamplerV2``, with its :class:`ShotLedger`) and the unary engine
(:mod:`qdensity.execution.unary`, module functions on ``n x n`` orthogonal matrices).
"""

from __future__ import annotations

from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import (
    LedgerEntry,
    SamplerEngine,
    ShotLedger,
    bitarray_to_bits,
    bitarray_to_probabilities,
)

__all__ = [
    "ExactEngine",
    "SamplerEngine",
    "ShotLedger",
    "LedgerEntry",
    "bitarray_to_probabilities",
    "bitarray_to_bits",
]
