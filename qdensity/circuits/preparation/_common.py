"""Shared pieces of the density-state preparations (Fig. 1a/b/c, Fig. 13; Supp. I.2-I.3).

Register names of the ancilla circuits, the input checks every builder runs (sub-unitaries,
loader, ``alpha``, parameter names), and the two appenders they share: a circuit's gates on
given qubits, and the ``mix``/``data`` skeleton with ``Load(sqrt(alpha))`` and ``V(x)``.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import Gate, Parameter, QuantumCircuit, QuantumRegister

from qdensity.circuits.loaders import distribution_loader
from qdensity.validation import check_distribution

#: Name of the ancilla register that carries ``Load(sqrt(alpha))`` (register A of Fig. 1).
MIX_REGISTER = "mix"
#: Name of the data register (register B of Fig. 1).
DATA_REGISTER = "data"

_PASS_THROUGH = frozenset({"id", "delay"})
_NON_UNITARY = frozenset({"measure", "reset", "initialize", "store"})


def _check_unitary_circuit(circuit: QuantumCircuit, name: str) -> None:
    for inst in circuit.data:
        op = inst.operation
        if op.name == "barrier" or op.name in _PASS_THROUGH:
            continue
        if op.name in _NON_UNITARY or not isinstance(op, Gate) or inst.clbits:
            raise ValueError(
                f"{name} contains the non-unitary instruction {op.name!r}; only unitary gates "
                "are allowed (no measure, reset, control flow or classical bits)"
            )


def _check_sub_unitaries(sub_unitaries) -> list[QuantumCircuit]:
    """Declared sub-unitaries (a non-empty list of circuits of >= 1 qubits: every caller's
    declaration) that are unitary and of one width, as a list."""
    circuits = list(sub_unitaries)
    for k, circ in enumerate(circuits):
        _check_unitary_circuit(circ, f"sub_unitaries[{k}]")
    width = circuits[0].num_qubits
    for k, circ in enumerate(circuits[1:], start=1):
        if circ.num_qubits != width:
            raise ValueError(
                f"all sub-unitaries must have the same width: sub_unitaries[0] has {width} "
                f"qubits but sub_unitaries[{k}] has {circ.num_qubits}"
            )
    return circuits


def _check_loader(loader, width: int) -> QuantumCircuit | None:
    if loader is None:
        return None
    if loader.num_qubits != width:
        raise ValueError(
            f"loader must act on the {width} data qubits of the sub-unitaries, got "
            f"{loader.num_qubits} qubits"
        )
    _check_unitary_circuit(loader, "loader")
    return loader


def _check_parameter_names(named: list[tuple[str, QuantumCircuit]]) -> None:
    """Distinct ``Parameter`` objects with one name cannot live in one circuit: refuse early."""
    seen: dict[str, tuple[Parameter, str]] = {}
    for label, circ in named:
        for p in circ.parameters:
            if p.name in seen and seen[p.name][0] != p:
                raise ValueError(
                    f"{label} and {seen[p.name][1]} use different parameters with the same name "
                    f"{p.name!r}; give each circuit its own parameter_prefix, or pass the same "
                    "circuit object to share parameters"
                )
            seen.setdefault(p.name, (p, label))


def _check_alpha(alpha, num_sub_unitaries: int) -> np.ndarray:
    arr = check_distribution(alpha, "alpha")
    if arr.size != num_sub_unitaries:
        raise ValueError(
            f"alpha must have one entry per sub-unitary (length {num_sub_unitaries}), got "
            f"length {arr.size}"
        )
    return arr


def _append_circuit(out: QuantumCircuit, circuit: QuantumCircuit, qubits: list) -> None:
    """Append ``circuit``'s gates on ``qubits`` (by index), global phase included."""
    for inst in circuit.data:
        out.append(inst.operation, [qubits[circuit.find_bit(q).index] for q in inst.qubits])
    out.global_phase += circuit.global_phase


def _mix_and_data(
    circuits: list[QuantumCircuit], alpha: np.ndarray, loader: QuantumCircuit | None, name: str
) -> tuple[QuantumCircuit, QuantumRegister, QuantumRegister]:
    named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
    if loader is not None:
        named.append(("loader", loader))
    _check_parameter_names(named)
    mix = QuantumRegister(len(circuits), MIX_REGISTER)
    data = QuantumRegister(circuits[0].num_qubits, DATA_REGISTER)
    qc = QuantumCircuit(mix, data, name=name)
    _append_circuit(qc, distribution_loader(alpha), list(mix))
    if loader is not None:
        _append_circuit(qc, loader, list(data))
    return qc, mix, data
