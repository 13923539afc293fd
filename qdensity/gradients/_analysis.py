"""Commuting-gradient analyses of density-QNN sub-unitaries, derived once per structure.

An analysis (gradient observables, diagonalising circuits, estimator tables) depends on the
sub-unitary's circuit, the differentiated parameters and the readout, never on data or angles.
It is kept in a bounded cache keyed on exactly those: the circuit's structural fingerprint
(gates, qubits, parameter expressions), the parameters themselves and the readout's terms, so a
model rebuilt with the same circuits, or a second model sharing them, reuses it, and nothing is
written into the model.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

from qdensity.execution._compile import circuit_digest

__all__ = ["cached", "structure_key", "MAX_ENTRIES"]

#: Analyses kept (least recently used dropped first): a model of 255 sub-unitaries fits.
MAX_ENTRIES = 1024

_CACHE: OrderedDict = OrderedDict()


def structure_key(kind: str, circuit, params, readout: tuple,
                  fingerprint: tuple | None = None) -> tuple:
    """What an analysis of ``circuit`` w.r.t. ``params`` under ``readout`` depends on.

    ``fingerprint``: a key that determines ``circuit``'s structure, when the caller has one
    (``("encoded", digest of V, digest of U_k)`` for ``V(x) U_k``, the encoding's digest
    taken once per model rather than once per sub-unitary); default ``("plain",
    circuit_digest(circuit))`` (:func:`~qdensity.execution._compile.circuit_digest`: 32
    bytes, not the fingerprint's tuples)."""
    return (kind, ("plain", circuit_digest(circuit)) if fingerprint is None else fingerprint,
            tuple(params), readout)


def cached(key: tuple, build: Callable[[], object]):
    """``build()`` once per ``key`` (a ValueError it raises is kept and raised again)."""
    hit = _CACHE.get(key)
    if hit is None:
        try:
            hit = build()
        except ValueError as exc:
            hit = exc
        _CACHE[key] = hit
        while len(_CACHE) > MAX_ENTRIES:
            _CACHE.popitem(last=False)
    else:
        _CACHE.move_to_end(key)
    if isinstance(hit, ValueError):
        raise hit
    return hit

