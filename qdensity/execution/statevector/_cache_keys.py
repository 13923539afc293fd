"""What the adjoint engine's caches compare before reusing a compiled circuit or observable:
a circuit's outline (changed by almost any in-place edit) and an observable's terms."""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp


def _outline(circuit: QuantumCircuit) -> tuple:
    """What an in-place change of a circuit almost always alters, in microseconds: its
    number of instructions, of parameters, and its count of each gate (a full fingerprint
    costs about 2 µs per gate, more than a small adjoint call)."""
    return len(circuit.data), circuit.num_parameters, tuple(circuit.count_ops().items())


def _terms(obs) -> tuple | None:
    """A copy of a Pauli observable's terms (None for a label, which cannot change)."""
    if isinstance(obs, SparsePauliOp):
        return obs.paulis.x.copy(), obs.paulis.z.copy(), obs.paulis.phase.copy(), obs.coeffs.copy()
    return None


def _same_terms(obs, terms: tuple | None) -> bool:
    if terms is None:
        return not isinstance(obs, SparsePauliOp)
    now = _terms(obs)
    return now is not None and all(a.shape == b.shape and np.array_equal(a, b)
                                   for a, b in zip(now, terms, strict=True))
