"""Controlled sub-unitaries, gate by gate (Fig. 1b, Fig. 13a; Supp. I.2).

:func:`controlled_subunitary` controls only what needs controlling: a gate
``V R(theta) V^dagger`` gets a controlled rotation between uncontrolled ``V`` and ``V^dagger``
(they cancel when the control is off). Free parameters stay parameters, so one template
serves every parameter row. The deterministic and LCU preparations share it.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import (
    Gate,
    Instruction,
    ParameterExpression,
    QuantumCircuit,
    QuantumRegister,
)
from qiskit.circuit.library import (
    CRXGate,
    CRYGate,
    CRZGate,
    CUGate,
    PhaseGate,
)
from qiskit.circuit.library.standard_gates import get_standard_gate_name_mapping
from qiskit.quantum_info import Operator, SparsePauliOp

from qdensity.analysis.gate_registry import EVOLUTION, FBS, GATES, GIVENS_GATES, PHASE_GATES, RBS
from qdensity.circuits.preparation._common import _NON_UNITARY, _PASS_THROUGH, DATA_REGISTER
from qdensity.validation import Circuit, validates

__all__ = ["controlled_subunitary"]

# Single-qubit rotations and their controlled versions: exp(-i theta P / 2) -> C-exp(...).
_CONTROLLED_ROTATION = {"rx": CRXGate, "ry": CRYGate, "rz": CRZGate}
# Two-qubit Pauli rotations exp(-i theta P (x) P' / 2); letters per gate qubit 0, 1.
_PAULI_ROTATIONS = {"rxx": "XX", "ryy": "YY", "rzz": "ZZ", "rzx": "ZX"}
_MAX_DEFINITION_DEPTH = 12
_STANDARD_GATES = frozenset(get_standard_gate_name_mapping())
_IDENTITY_ATOL = 1e-10
_MAX_SKELETON_QUBITS = 10  # widest definition whose skeleton is checked by its matrix


def _is_free(value) -> bool:
    return isinstance(value, ParameterExpression) and bool(value.parameters)


def _has_free_parameter(op: Instruction) -> bool:
    return any(_is_free(p) for p in op.params)


def _nonzero_phase(phase) -> bool:
    if _is_free(phase):
        return True
    return abs(float(phase)) > 0.0


def _append_controlled_phase(out: QuantumCircuit, ctrl, phase) -> None:
    """``e^{i phase}`` applied only when the control is on: a phase gate on the control."""
    if _nonzero_phase(phase):
        out.append(PhaseGate(phase), [ctrl])


def _append_controlled_rbs(out: QuantumCircuit, ctrl, qi, qj, theta) -> None:
    """Controlled RBS: ``W (CRY(theta) (x) CRY(-theta)) W^dagger``, ``W = (H (x) H) CZ``.

    ``RBSGate._define`` is ``H H . CZ . RY(theta) RY(-theta) . CZ . H H``; only the two
    rotations are controlled, the conjugation cancels when the control is off.
    """
    out.h([qi, qj])
    out.cz(qi, qj)
    out.append(CRYGate(theta), [ctrl, qi])
    out.append(CRYGate(-theta), [ctrl, qj])
    out.cz(qi, qj)
    out.h([qi, qj])


def _append_controlled_fbs(out: QuantumCircuit, ctrl, qubits, theta) -> None:
    """Controlled FBS (Supp. E.2, eq. 25): parity CNOTs and CZs uncontrolled, RBS controlled."""
    m = len(qubits)
    first, last = qubits[0], qubits[-1]
    if m == 2:
        _append_controlled_rbs(out, ctrl, first, last, theta)
        return
    parity = qubits[1]
    for k in range(2, m - 1):
        out.cx(qubits[k], parity)
    out.cz(parity, first)
    _append_controlled_rbs(out, ctrl, first, last, theta)
    out.cz(parity, first)
    for k in reversed(range(2, m - 1)):
        out.cx(qubits[k], parity)


def _append_controlled_pauli_rotation(
    out: QuantumCircuit, ctrl, qubits, letters: str, theta
) -> None:
    """Controlled ``exp(-i theta P / 2)`` for a Pauli string ``P`` (``letters[i]`` on qubit i).

    Basis change to Z on every active qubit, CNOT parity ladder onto the last active qubit,
    one CRZ from the control, ladder and basis change undone (uncontrolled: they cancel when
    the control is off). An all-identity string is a global phase ``e^{-i theta / 2}``,
    which becomes a phase gate on the control.
    """
    active = [(q, p) for q, p in zip(qubits, letters, strict=True) if p != "I"]
    if not active:
        _append_controlled_phase(out, ctrl, -theta / 2)
        return
    for q, p in active:  # V^dagger: X -> H, Y -> H S^dagger (S^dagger first)
        if p == "Y":
            out.sdg(q)
        if p in "XY":
            out.h(q)
    target = active[-1][0]
    for q, _ in active[:-1]:
        out.cx(q, target)
    out.append(CRZGate(theta), [ctrl, target])
    for q, _ in reversed(active[:-1]):
        out.cx(q, target)
    for q, p in active:  # V = S H (H first)
        if p in "XY":
            out.h(q)
        if p == "Y":
            out.s(q)


def _single_pauli_rotation(op: Gate) -> tuple[str, object] | None:
    """``(letters, theta)`` with ``op = exp(-i theta P / 2)`` for a one-term PauliEvolutionGate."""
    operator = op.operator
    if isinstance(operator, list):
        return None
    spo = SparsePauliOp(operator)
    if len(spo) != 1:
        return None
    pauli = spo.paulis[0]
    coeff = complex(spo.coeffs[0]) * (-1j) ** int(pauli.phase)
    if abs(coeff.imag) > 1e-14 or coeff.real == 0.0:
        return None
    letters = "".join(
        "Y" if (x and z) else "X" if x else "Z" if z else "I"
        for x, z in zip(pauli.x, pauli.z, strict=True)
    )
    time = op.params[0]
    return letters, time * (2.0 * coeff.real)


def _skeleton_is_identity(definition: QuantumCircuit, controllable: list[bool]) -> bool:
    """Whether the instructions not marked controllable multiply to the identity."""
    if definition.num_qubits > _MAX_SKELETON_QUBITS:
        return False
    skeleton = QuantumCircuit(definition.num_qubits)
    for inst, keep_out in zip(definition.data, controllable, strict=True):
        if keep_out:
            continue
        if _has_free_parameter(inst.operation):
            return False
        idx = [definition.find_bit(q).index for q in inst.qubits]
        skeleton.append(inst.operation, idx)
    if skeleton.size() == 0:
        return True
    try:
        mat = Operator(skeleton).data
    except Exception:  # noqa: BLE001 - an instruction without a matrix: no shortcut
        return False
    return bool(np.allclose(mat, np.eye(mat.shape[0]), atol=_IDENTITY_ATOL, rtol=0.0))


def _has_cheap_rule(op: Instruction) -> bool:
    name = op.name
    if name in _CONTROLLED_ROTATION or name in _PAULI_ROTATIONS:
        return True
    if name in GIVENS_GATES or name in PHASE_GATES or name in ("u", "u3", "global_phase"):
        return True
    return GATES.get(name) is EVOLUTION and _single_pauli_rotation(op) is not None


def _append_controlled_instruction(
    out: QuantumCircuit, ctrl, qubits: list, op: Instruction, depth: int = 0
) -> None:
    """Append controlled-``op`` on ``[ctrl] + qubits`` to ``out`` (see controlled_subunitary)."""
    name = op.name
    if name == "barrier":
        out.barrier([ctrl, *qubits])
        return
    if name in _PASS_THROUGH:
        return
    if name in _NON_UNITARY or not isinstance(op, Gate) or op.num_clbits:
        raise ValueError(
            f"sub-unitary contains the non-unitary instruction {name!r}; sub-unitaries must be "
            "unitary gates only (no measure, reset, control flow or classical bits)"
        )
    params = op.params
    if name in _CONTROLLED_ROTATION:
        out.append(_CONTROLLED_ROTATION[name](params[0]), [ctrl, *qubits])
        return
    if name in PHASE_GATES:
        out.append(PhaseGate(params[0]).control(1), [ctrl, *qubits])
        return
    if name in ("u", "u3"):
        out.append(CUGate(params[0], params[1], params[2], 0.0), [ctrl, *qubits])
        return
    if name == "global_phase":
        _append_controlled_phase(out, ctrl, params[0])
        return
    if GATES.get(name) is RBS:
        _append_controlled_rbs(out, ctrl, qubits[0], qubits[1], params[0])
        return
    if GATES.get(name) is FBS:
        _append_controlled_fbs(out, ctrl, qubits, params[0])
        return
    if name in _PAULI_ROTATIONS:
        _append_controlled_pauli_rotation(out, ctrl, qubits, _PAULI_ROTATIONS[name], params[0])
        return
    if GATES.get(name) is EVOLUTION:
        single = _single_pauli_rotation(op)
        if single is not None:
            _append_controlled_pauli_rotation(out, ctrl, qubits, single[0], single[1])
            return
    if not op.params and name in _STANDARD_GATES:  # x, h, cx, cz, swap, ccx, ...
        out.append(op.control(1), [ctrl, *qubits])
        return
    definition = op.definition if depth < _MAX_DEFINITION_DEPTH else None
    if definition is not None and _is_recursable(op, definition):
        # Control only what needs it: if the gates without a cheap controlled form multiply
        # to the identity, they stay uncontrolled (they cancel when the control is off).
        cheap = [_has_cheap_rule(inst.operation) for inst in definition.data]
        skip_control = _skeleton_is_identity(definition, cheap)
        if skip_control or _has_free_parameter(op):
            _append_controlled_phase(out, ctrl, definition.global_phase)
            for inst, is_cheap in zip(definition.data, cheap, strict=True):
                sub_qubits = [qubits[definition.find_bit(q).index] for q in inst.qubits]
                if skip_control and not is_cheap:
                    out.append(inst.operation, sub_qubits)
                else:
                    _append_controlled_instruction(out, ctrl, sub_qubits, inst.operation, depth + 1)
            return
    # Fixed gates (cx -> ccx, h -> ch, swap -> cswap, ...) and anything else.
    out.append(op.control(1), [ctrl, *qubits])


def _is_recursable(op: Instruction, definition: QuantumCircuit) -> bool:
    """A definition worth descending into (not a trivial self-reference)."""
    if len(definition.data) == 1 and definition.data[0].operation.name == op.name:
        return False
    return all(not inst.clbits for inst in definition.data)


@validates(circuit=Circuit(min_qubits=1))
def controlled_subunitary(circuit: QuantumCircuit) -> QuantumCircuit:
    """Controlled-``U`` for a sub-unitary circuit ``U``, gate by gate (Fig. 1b, Fig. 13a).

    Each gate is controlled as cheaply as its structure allows:

    * ``rx, ry, rz`` -> ``crx, cry, crz``; ``p`` -> ``cp``; ``u`` -> ``cu``;
    * ``rbs(theta) = W (RY(theta) (x) RY(-theta)) W^dagger``, ``W = (H (x) H) CZ``: only the
      two ``RY`` are controlled (2 CZ + 2 CRY instead of a generic controlled 2-qubit gate);
    * ``fbs``: its parity CNOTs and CZs stay uncontrolled (they cancel when the RBS is
      skipped), the RBS is controlled as above;
    * ``rxx, ryy, rzz, rzx`` and a one-term ``PauliEvolutionGate``: basis change, CNOT parity
      ladder and one ``crz``, with only the ``crz`` controlled;
    * another parameterised gate: its definition, controlling only the rotations when the
      remaining gates multiply to the identity, else every gate;
    * fixed gates (``cx, cz, h, x, swap, ...``): ``Gate.control(1)`` (``ccx, ccz, ch, ...``);
    * the circuit's global phase ``gamma``: a phase gate ``p(gamma)`` on the control.

    Parameters
    ----------
    circuit : QuantumCircuit
        The sub-unitary ``U`` on ``n`` qubits, parameterised or bound; unitary gates only.

    Returns
    -------
    QuantumCircuit
        ``1 + n`` qubits: register ``"ctrl"`` (qubit 0) then ``"data"`` (qubit ``1 + q``
        carries qubit ``q`` of ``U``). Its operator is ``|0><0| (x) I + |1><1| (x) U`` with
        the control as the least significant qubit, i.e. ``kron(I, P0) + kron(U, P1)`` in
        Qiskit's ordering. Free parameters of ``U`` stay free (same ``Parameter`` objects).

    Raises
    ------
    TypeError
        If ``circuit`` is not a ``QuantumCircuit``.
    ValueError
        If it has no qubits or contains a non-unitary instruction.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> cu = controlled_subunitary(pyramid(3))
    >>> cu.num_qubits, cu.num_parameters
    (4, 3)
    """
    n = circuit.num_qubits
    ctrl = QuantumRegister(1, "ctrl")
    data = QuantumRegister(n, DATA_REGISTER)
    out = QuantumCircuit(ctrl, data, name=f"c_{circuit.name}")
    _append_controlled_circuit(out, ctrl[0], list(data), circuit)
    return out


def _append_controlled_circuit(out: QuantumCircuit, ctrl, data: list, circuit: QuantumCircuit):
    _append_controlled_phase(out, ctrl, circuit.global_phase)
    for inst in circuit.data:
        qubits = [data[circuit.find_bit(q).index] for q in inst.qubits]
        if inst.clbits:
            raise ValueError(
                f"sub-unitary {circuit.name!r} contains {inst.operation.name!r} acting on "
                "classical bits; sub-unitaries must be unitary gates only"
            )
        _append_controlled_instruction(out, ctrl, qubits, inst.operation)
