"""The measured circuits of unary l-infinity tomography (Supp. F; Landman et al. Fig. 18).

:func:`tomography_circuits` gives the three circuits (computational basis, ``RBS(pi/4)`` on
the even pairs, on the odd pairs); :func:`bridge_circuit` an extra one with ``RBS(pi/4)`` on
arbitrary disjoint pairs, to join sign components across a gap.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from qiskit.circuit import QuantumCircuit

from qdensity.circuits.gates import RBSGate
from qdensity.circuits.measure import measured
from qdensity.circuits.tomography._common import _REGISTER, _check_pairs, _layer_pairs
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    Circuit,
    Interval,
    SequenceOf,
    check_circuit,
    validates,
)

__all__ = ["tomography_circuits", "bridge_circuit"]


def _check_unmeasured(circuit, name: str = "circuit") -> QuantumCircuit:
    check_circuit(circuit, name)
    if circuit.num_clbits:
        raise ValueError(
            f"{name} must have no classical bits (the tomography circuits add their own "
            f"'{_REGISTER}' register), got {circuit.num_clbits}"
        )
    if circuit.num_qubits < 2:
        raise ValueError(f"{name} must have >= 2 qubits, got {circuit.num_qubits}")
    return circuit


def _measured(circuit: QuantumCircuit, pairs: Sequence[tuple[int, int]], name: str):
    out = circuit.copy(name=name)
    for a, b in pairs:
        out.append(RBSGate(math.pi / 4), [a, b])
    return measured(out, _REGISTER)


@validates(circuit=Circuit(min_qubits=2))
def tomography_circuits(circuit: QuantumCircuit) -> list[QuantumCircuit]:
    """The three measured circuits of unary l-infinity tomography (Supp. F, Landman Fig. 18).

    Parameters
    ----------
    circuit : QuantumCircuit
        Prepares a unary state on ``n >= 2`` qubits (loader + orthogonal layer, say); no
        classical bits. May be parameterised: the outputs keep its parameters, in the same
        ``circuit.parameters`` order, so one parameter array serves all three PUBs.

    Returns
    -------
    list of QuantumCircuit, length 3
        ``[circuit + measure, circuit + RBS(pi/4) on (0,1),(2,3),... + measure,
        circuit + RBS(pi/4) on (1,2),(3,4),... + measure]``; each measures every qubit ``j``
        into bit ``j`` of a classical register named ``"meas"``.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> circuits = tomography_circuits(pyramid(4))
    >>> [c.count_ops().get("rbs", 0) for c in circuits]
    [6, 8, 7]
    """
    _check_unmeasured(circuit)
    n = circuit.num_qubits
    base = circuit.name or "circuit"
    return [
        _measured(circuit, [], f"{base}_tomo_z"),
        _measured(circuit, _layer_pairs(n, 0), f"{base}_tomo_even"),
        _measured(circuit, _layer_pairs(n, 1), f"{base}_tomo_odd"),
    ]


@validates(
    circuit=Circuit(min_qubits=2),
    pairs=SequenceOf(SequenceOf(Interval(int, 0, MAX_CIRCUIT_QUBITS), min_len=2, max_len=2),
                     min_len=0),
)
def bridge_circuit(circuit: QuantumCircuit, pairs: Sequence[tuple[int, int]]) -> QuantumCircuit:
    """An extra tomography circuit with ``RBS(pi/4)`` on arbitrary disjoint qubit pairs.

    Use it to fix the relative sign of amplitudes across a gap that the three circuits of
    :func:`tomography_circuits` cannot bridge (see the package notes). For a pair ``(a, b)``
    it measures ``D_ab = 2 sign(y_a y_b) min(|y_a|, |y_b|)`` just as the even/odd layers do
    for neighbours. Pairs need not be adjacent (on hardware the transpiler routes them).

    Parameters
    ----------
    circuit : QuantumCircuit
        As for :func:`tomography_circuits`.
    pairs : sequence of (int, int)
        Disjoint pairs ``(a, b)``, ``a != b``; the gate is ``RBS(pi/4)`` on ``[a, b]``.

    Returns
    -------
    QuantumCircuit
        ``circuit`` + the RBS layer + measurement of every qubit into register ``"meas"``.
        Pass ``(pairs, counts)`` to ``reconstruct(..., extra=[...])``.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> bridge_circuit(pyramid(5), [(0, 3), (1, 4)]).count_ops()["rbs"]
    12
    """
    _check_unmeasured(circuit)
    checked = _check_pairs(pairs, circuit.num_qubits)
    return _measured(circuit, checked, f"{circuit.name or 'circuit'}_tomo_bridge")
