"""Diagonalising circuits for commuting-generator gradients (paper Supp. F.3).

The symplectic Clifford diagonalisation of a commuting Pauli set lives with the Pauli algebra in
:func:`qdensity.analysis.pauli.diagonalising_clifford`; this module builds the RBS layer that
diagonalises RBS gradient observables.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.circuits.gates import RBSGate
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
    used: set[int] = set()
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
        circ.append(RBSGate(np.pi / 4), [i, j])
    return circ
