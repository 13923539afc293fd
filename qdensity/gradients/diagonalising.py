"""Diagonalising circuits for commuting-generator gradients (paper Supp. F.3).

The symplectic Clifford diagonalisation of a commuting Pauli set lives with the Pauli algebra in
:func:`qdensity.analysis.pauli.diagonalising_clifford`; this module builds the RBS layer that
diagonalises RBS gradient observables (:func:`rbs_diagonalising_layer`), decides whether that
layer applies to a block (``_rbs_layer_for``), appends a diagonalising tail and the measurement
to a circuit (``_measured``) and tabulates diagonal observables on every computational-basis
outcome (``_diagonal_matrix``), the post-processing of every gradient circuit.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from qiskit.circuit import CircuitInstruction, Parameter, QuantumCircuit
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.analysis._conjugate import conjugate_by_layer
from qdensity.analysis.blocks import _ATOL, _terms_of, _Trainable
from qdensity.analysis.gate_registry import GATES, RBS
from qdensity.analysis.pauli import ZStringTable
from qdensity.circuits._copying import append_owned, extend
from qdensity.circuits.gates import RBSGate, rbs_matrix
from qdensity.circuits.measure import measured
from qdensity.validation import check_positive_int

__all__ = ["rbs_diagonalising_layer"]


def rbs_diagonalising_layer(num_qubits: int, pairs: Iterable[tuple[int, int]]) -> QuantumCircuit:
    """One layer of ``RBS(pi/4)`` gates on disjoint pairs (paper Supp. F.3).

    On a pair ``(i, j)``, ``RBS(pi/4) (X_i X_j + Y_i Y_j) RBS(pi/4)^dagger = Z_j - Z_i``: it is the
    diagonalising unitary of the RBS gradient observables, and the sign-extraction layer of
    unary-state tomography.

    Parameters
    ----------
    num_qubits : int
        Register width ``n``.
    pairs : iterable of (int, int)
        Disjoint pairs ``(i, j)``, ``i != j``; the gate acts on ``[i, j]`` in the given order.

    Returns
    -------
    QuantumCircuit
        ``n`` qubits, one ``RBSGate(pi/4)`` per pair, depth 1.

    Examples
    --------
    >>> rbs_diagonalising_layer(4, [(0, 1), (2, 3)]).count_ops()["rbs"]
    2
    """
    n = check_positive_int(num_qubits, "num_qubits", minimum=2)
    circ = QuantumCircuit(n, name="rbs_diagonalise")
    bits = circ.qubits
    gate = RBSGate(np.pi / 4)  # one gate without parameters serves every pair, as Qiskit's
    used: set[int] = set()     # append(..., copy=True) shares such a gate
    gates = []
    for pair in pairs:
        try:
            i, j = (int(v) for v in pair)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"pairs must hold (int, int) tuples, got {pair!r}") from exc
        if i == j or not (0 <= i < n and 0 <= j < n):
            raise ValueError(f"pair {pair!r} must be two different qubits in [0, {n})")
        if i in used or j in used:
            raise ValueError(f"pairs must be disjoint; pair {pair!r} reuses a qubit")
        used.update((i, j))
        gates.append(CircuitInstruction(gate, (bits[i], bits[j])))
    append_owned(circ, gates)  # checked above: distinct qubits in range
    return circ


def _diagonal_matrix(diag_ops: Sequence[SparsePauliOp], num_qubits: int) -> ZStringTable:
    """Values of diagonal operators on outcomes, one column each: a :class:`ZStringTable`
    (``.dense()`` is the ``(2**n, len(diag_ops))`` table at small ``n``)."""
    return ZStringTable.from_operators(diag_ops, num_qubits, atol=_ATOL)


def _measured(circuit: QuantumCircuit, tail: QuantumCircuit | None) -> QuantumCircuit:
    """``measured(circuit + barrier + tail)``: one copy of ``circuit`` (``QuantumCircuit.copy``),
    the tail's gates appended to it (:func:`qdensity.circuits._copying.extend`: no
    ``compose``), measured in place."""
    out = circuit.copy()
    if tail is not None and tail.size():
        out.barrier()
        extend(out, tail)
    return measured(out, inplace=True)


def _measured_rbs(circuit: QuantumCircuit, pairs: Sequence[tuple[int, int]]) -> QuantumCircuit:
    """``_measured(circuit, rbs_diagonalising_layer(n, pairs))`` for ``pairs`` from
    :func:`_rbs_pairs` (disjoint, on the circuit's qubits): the layer's one ``RBS(pi/4)`` gate
    appended on each pair of the copy itself, with no layer circuit built and copied over."""
    out = circuit.copy()
    if pairs:
        out.barrier()
        gate, bits = RBSGate(np.pi / 4), out.qubits  # shared, as in rbs_diagonalising_layer
        append_owned(out, [CircuitInstruction(gate, (bits[i], bits[j])) for i, j in pairs],
                     new=True)
    return measured(out, inplace=True)


def _rbs_pairs(trainables: Sequence[_Trainable]) -> list[tuple[int, int]] | None:
    """The qubit pairs of a block of RBS gates on disjoint pairs (in gate order), else None."""
    if not trainables or any(GATES.get(t.name) is not RBS for t in trainables):
        return None
    stack = _terms_of(trainables)  # each gate's support: OR of its terms' bits, at once
    # bits packed 8 a byte (7x faster at 1,024 qubits)
    n = stack.x.shape[1]
    packed = np.bitwise_or.reduceat(np.packbits(stack.x | stack.z, axis=1), stack.starts[:-1],
                                    axis=0)
    if np.any(np.bitwise_count(packed).sum(axis=1) != 2):
        return None
    support = np.unpackbits(packed, axis=1, count=n).view(bool)
    pairs = list(dict.fromkeys((int(a), int(b))
                               for a, b in np.nonzero(support)[1].reshape(-1, 2).tolist()))
    used = [q for p in pairs for q in p]
    if len(used) != len(set(used)):
        return None
    return pairs


def _rbs_layer_for(
    trainables: Sequence[_Trainable], observables: dict[Parameter, SparsePauliOp], n: int
) -> tuple[QuantumCircuit, dict[Parameter, SparsePauliOp]] | None:
    """The RBS(pi/4) layer of Supp. F.3 when every trainable gate is an RBS, the pairs are
    disjoint and the layer diagonalises every gradient observable; else None."""
    pairs = _rbs_pairs(trainables)
    if pairs is None:
        return None
    layer = rbs_diagonalising_layer(n, pairs)
    items = list(observables.items())
    if not items:
        return layer, {}
    # every operator's strings through the layer at once, then summed per operator
    x = np.concatenate([op.paulis.x for _, op in items])
    z = np.concatenate([op.paulis.z for _, op in items])
    coeffs = np.concatenate([op.coeffs * (-1j) ** op.paulis.phase for _, op in items])
    owner = np.repeat(np.arange(len(items)), [op.size for _, op in items])
    x, z, coeffs, src = conjugate_by_layer(x, z, coeffs, rbs_matrix(np.pi / 4), np.array(pairs))
    keys = np.concatenate([owner[src][:, None],
                           np.packbits(np.concatenate([x, z], axis=1), axis=1)], axis=1)
    uniq, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    total = (np.bincount(inv, weights=coeffs.real, minlength=len(uniq))
             + 1j * np.bincount(inv, weights=coeffs.imag, minlength=len(uniq)))
    keep = np.flatnonzero(np.abs(total) > _ATOL)
    rows = first[keep]
    if x[rows].any():
        return None
    bounds = np.searchsorted(uniq[keep, 0], np.arange(len(items) + 1))
    zero_bits = np.zeros((1, n), dtype=bool)
    diag = {}
    for i, (p, _) in enumerate(items):
        sel = rows[bounds[i]:bounds[i + 1]]
        if sel.size:
            diag[p] = SparsePauliOp(PauliList.from_symplectic(z[sel], x[sel]),
                                    total[keep[bounds[i]:bounds[i + 1]]])
        else:
            diag[p] = SparsePauliOp(PauliList.from_symplectic(zero_bits, zero_bits), [0.0])
    return layer, diag
