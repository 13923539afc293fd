"""The line a matrix-product-state simulation lays a device circuit's active qubits on.

Aer's ``matrix_product_state`` method puts the qubits it simulates on a line in index order and
brings the two qubits of every gate next to each other by swaps along that line (and back). A
circuit transpiled onto a heavy-hex device acts on physical qubits whose index order follows the
device's rows, not the circuit's couplings: a 32-qubit unary model on the 127-qubit
``fake_kyiv`` has gates between qubits up to 9 apart on Aer's line. :func:`line_order` numbers
the active qubits by reverse Cuthill-McKee on the graph of the circuits' two-qubit gates (the
bandwidth drops to 3 there) and :func:`relabelled` rewrites the circuits on those positions;
the noise served with them is renumbered the same way, so the channel is unchanged.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit, QuantumRegister
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

__all__: list[str] = []

_SKIPPED = frozenset({"barrier"})


def line_order(circuits: list[QuantumCircuit], qubits: frozenset[int]) -> dict[int, int] | None:
    """Position on the line of each active qubit, or None when the circuits cannot be
    relabelled (an instruction on three or more qubits, control flow or a condition).

    Parameters
    ----------
    circuits : list of QuantumCircuit
    qubits : frozenset of int
        Their active qubits (indices).

    Returns
    -------
    dict or None
        ``{qubit index: position}``, positions ``0 .. len(qubits) - 1``.
    """
    used = sorted(qubits)
    where = {q: i for i, q in enumerate(used)}
    rows: list[int] = []
    for circ in circuits:
        for inst in circ.data:
            op = inst.operation
            if op.name in _SKIPPED:
                continue
            if (len(inst.qubits) > 2 or getattr(op, "blocks", None)
                    or getattr(op, "condition", None) is not None):
                return None
            if len(inst.qubits) == 2:
                rows.extend(where[circ.find_bit(q).index] for q in inst.qubits)
    m = len(used)
    a, b = np.asarray(rows[0::2], dtype=np.int64), np.asarray(rows[1::2], dtype=np.int64)
    graph = coo_matrix((np.ones(2 * len(a)), (np.r_[a, b], np.r_[b, a])), shape=(m, m)).tocsr()
    order = reverse_cuthill_mckee(graph, symmetric_mode=True)
    return {used[int(o)]: k for k, o in enumerate(order)}


def relabelled(circuit: QuantumCircuit, position: dict[int, int]) -> QuantumCircuit:
    """``circuit`` on ``len(position)`` qubits, qubit ``q`` moved to ``position[q]``; the
    classical bits, parameters, metadata and global phase are kept, barriers dropped."""
    qreg = QuantumRegister(len(position), "q")
    out = QuantumCircuit(qreg, list(circuit.clbits), name=circuit.name,
                         global_phase=circuit.global_phase, metadata=circuit.metadata)
    for creg in circuit.cregs:  # over the same bits, in the same order
        out.add_register(creg)
    for inst in circuit.data:
        if inst.operation.name in _SKIPPED:
            continue
        out._append(inst.operation, [qreg[position[circuit.find_bit(q).index]]
                                     for q in inst.qubits], inst.clbits)
    return out


def renumbered(errors: dict, position: dict[int, int]) -> dict:
    """A serialised noise model's ``gate_qubits`` moved to ``position`` (errors on qubits
    outside it are left out)."""
    out = []
    for e in errors["errors"]:
        if "gate_qubits" not in e:
            out.append(e)
            continue
        qs = [[position[q] for q in g] for g in e["gate_qubits"] if set(g) <= position.keys()]
        if qs:
            out.append({**e, "gate_qubits": qs})
    return {**errors, "errors": out}
