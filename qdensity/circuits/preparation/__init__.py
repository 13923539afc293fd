"""Circuits that prepare the density-QNN state (paper Fig. 1a/b/c, Fig. 13, Supp. I.2-I.3).

A density QNN (paper eq. 1) prepares

    rho(theta, alpha, x) = sum_k alpha_k U_k(theta_k) |x><x| U_k(theta_k)^dagger

from ``K`` sub-unitaries ``U_k`` on ``n`` data qubits and a distribution ``alpha``. This
module builds every way the paper gives to prepare it, at gate level:

=============================  ==========  ==========================================
builder                        figure      what one shot does
=============================  ==========  ==========================================
:func:`randomised_circuits`    Fig. 1c     ``V(x)`` then ``U_k``; ``k ~ alpha`` per shot
:func:`deterministic_circuit`  Fig. 1b/13a  ``Load(sqrt(alpha))`` on ``mix``, controlled
                                           ``U_k``; the ``data`` marginal is ``rho``
:func:`lcu_circuit`            Fig. 1a     Fig. 1b then ``Load(sqrt(alpha))^dagger``;
                                           post-select ``mix = 0...0``
:func:`hw_generative_circuit`  Fig. 13b    ``V = 1``, HW-preserving ``U_k``:
                                           ``U_k^dagger . CNOT . U_k`` per ``k``
=============================  ==========  ==========================================

Register layout of the ancilla circuits: register ``"mix"`` (``K`` qubits, circuit qubits
``0 .. K-1``, the register A of the figures, drawn on top) then register ``"data"``
(``n`` qubits, circuit qubits ``K .. K+n-1``, register B). Qubit ``k`` of ``mix`` controls
``U_k``; data qubit ``q`` of a sub-unitary is ``data[q]``.

Controlled sub-unitaries are built gate by gate by :func:`controlled_subunitary`, which
controls only what needs controlling: a gate ``V R(theta) V^dagger`` gets a controlled
rotation between uncontrolled ``V`` and ``V^dagger`` (they cancel when the control is off).
Free parameters stay parameters, so one template serves every parameter row.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import (
    Gate,
    Instruction,
    Parameter,
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
from qiskit.quantum_info import Operator, SparsePauliOp, Statevector

from qdensity.analysis.structure import is_hamming_weight_preserving
from qdensity.circuits.loaders import distribution_loader
from qdensity.validation import check_circuit, check_distribution, check_positive_int

__all__ = [
    "controlled_subunitary",
    "randomised_circuits",
    "deterministic_circuit",
    "lcu_circuit",
    "lcu_success_probability",
    "lcu_postselected_state",
    "hw_generative_circuit",
    "PreparationCircuits",
    "prepare_all",
    "MIX_REGISTER",
    "DATA_REGISTER",
]

#: Name of the ancilla register that carries ``Load(sqrt(alpha))`` (register A of Fig. 1).
MIX_REGISTER = "mix"
#: Name of the data register (register B of Fig. 1).
DATA_REGISTER = "data"

_PASS_THROUGH = frozenset({"id", "delay"})
_NON_UNITARY = frozenset({"measure", "reset", "initialize", "store"})
# Single-qubit rotations and their controlled versions: exp(-i theta P / 2) -> C-exp(...).
_CONTROLLED_ROTATION = {"rx": CRXGate, "ry": CRYGate, "rz": CRZGate}
# Two-qubit Pauli rotations exp(-i theta P (x) P' / 2); letters per gate qubit 0, 1.
_PAULI_ROTATIONS = {"rxx": "XX", "ryy": "YY", "rzz": "ZZ", "rzx": "ZX"}
_MAX_DEFINITION_DEPTH = 12
_STANDARD_GATES = frozenset(get_standard_gate_name_mapping())
_IDENTITY_ATOL = 1e-10
_MAX_SKELETON_QUBITS = 10  # widest definition whose skeleton is checked by its matrix


# --------------------------------------------------------------------------------------
# Controlled sub-unitaries
# --------------------------------------------------------------------------------------


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
    if name in ("rbs", "fbs", "p", "u1", "u", "u3", "global_phase"):
        return True
    return name == "PauliEvolution" and _single_pauli_rotation(op) is not None


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
    if name in ("p", "u1"):
        out.append(PhaseGate(params[0]).control(1), [ctrl, *qubits])
        return
    if name in ("u", "u3"):
        out.append(CUGate(params[0], params[1], params[2], 0.0), [ctrl, *qubits])
        return
    if name == "global_phase":
        _append_controlled_phase(out, ctrl, params[0])
        return
    if name == "rbs":
        _append_controlled_rbs(out, ctrl, qubits[0], qubits[1], params[0])
        return
    if name == "fbs":
        _append_controlled_fbs(out, ctrl, qubits, params[0])
        return
    if name in _PAULI_ROTATIONS:
        _append_controlled_pauli_rotation(out, ctrl, qubits, _PAULI_ROTATIONS[name], params[0])
        return
    if name == "PauliEvolution":
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
                    _append_controlled_instruction(
                        out, ctrl, sub_qubits, inst.operation, depth + 1
                    )
            return
    # Fixed gates (cx -> ccx, h -> ch, swap -> cswap, ...) and anything else.
    out.append(op.control(1), [ctrl, *qubits])


def _is_recursable(op: Instruction, definition: QuantumCircuit) -> bool:
    """A definition worth descending into (not a trivial self-reference)."""
    if len(definition.data) == 1 and definition.data[0].operation.name == op.name:
        return False
    return all(not inst.clbits for inst in definition.data)


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
    >>> from qdensity.ansatze import pyramid
    >>> cu = controlled_subunitary(pyramid(3))
    >>> cu.num_qubits, cu.num_parameters
    (4, 3)
    """
    circuit = check_circuit(circuit, "circuit")
    n = circuit.num_qubits
    if n < 1:
        raise ValueError("circuit must act on at least one qubit, got 0 qubits")
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


# --------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------


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
    """A non-empty list of unitary circuits of one width; parameter names consistent."""
    if isinstance(sub_unitaries, QuantumCircuit) or not isinstance(sub_unitaries, Sequence):
        raise TypeError(
            "sub_unitaries must be a list or tuple of QuantumCircuits (one per sub-unitary "
            f"U_k), got {type(sub_unitaries).__name__}"
        )
    if len(sub_unitaries) == 0:
        raise ValueError("sub_unitaries must hold at least one circuit (K >= 1), got K = 0")
    circuits = []
    for k, circ in enumerate(sub_unitaries):
        circ = check_circuit(circ, f"sub_unitaries[{k}]")
        _check_unitary_circuit(circ, f"sub_unitaries[{k}]")
        circuits.append(circ)
    width = circuits[0].num_qubits
    if width < 1:
        raise ValueError("sub_unitaries[0] must act on at least one qubit, got 0 qubits")
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
    loader = check_circuit(loader, "loader")
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


# --------------------------------------------------------------------------------------
# Builders
# --------------------------------------------------------------------------------------


def randomised_circuits(
    sub_unitaries: Sequence[QuantumCircuit], loader: QuantumCircuit | None = None
) -> list[QuantumCircuit]:
    """The randomised density QNN of Fig. 1c: one circuit ``U_k V(x)`` per sub-unitary.

    Each shot runs circuit ``k`` with probability ``alpha_k``; averaged over shots this
    prepares ``rho = sum_k alpha_k U_k |x><x| U_k^dagger`` (eq. 1) without ancillas or
    controlled gates. The shot schedule (how many shots for each ``k``) is the engine's job.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each, parameterised or bound.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits, applied first (e.g. a unary loader template whose data
        parameters are the ``ParameterVector`` ``"x"``). None: the data state is ``|0...0>``.

    Returns
    -------
    list of QuantumCircuit, length K
        Circuit ``k`` has one register ``"data"`` (``n`` qubits), ``V(x)`` then ``U_k``, name
        ``"density_randomised_k"`` and ``metadata["sub_unitary"] = k``.

    Raises
    ------
    TypeError, ValueError
        As in :func:`deterministic_circuit` (distinct parameters sharing a name across the
        sub-unitaries and loader are refused here too, so a name means one parameter in
        every preparation of the model).

    Examples
    --------
    >>> from qdensity.ansatze import pyramid
    >>> circuits = randomised_circuits([pyramid(4, parameter_prefix="a"),
    ...                                 pyramid(4, parameter_prefix="b")])
    >>> [c.num_parameters for c in circuits]
    [6, 6]
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    n = circuits[0].num_qubits
    loader = _check_loader(loader, n)
    # Same rule as the ancilla circuits, so that all preparations of one model accept the
    # same inputs and a parameter name means one parameter across them.
    named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
    if loader is not None:
        named.append(("loader", loader))
    _check_parameter_names(named)
    out = []
    for k, circ in enumerate(circuits):
        data = QuantumRegister(n, DATA_REGISTER)
        qc = QuantumCircuit(data, name=f"density_randomised_{k}")
        if loader is not None:
            _append_circuit(qc, loader, list(data))
        _append_circuit(qc, circ, list(data))
        qc.metadata = {"sub_unitary": k}
        out.append(qc)
    return out


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


def deterministic_circuit(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> QuantumCircuit:
    """The deterministic density QNN of Fig. 1b / Fig. 13a (Supp. I.2).

    ``Load(sqrt(alpha))`` puts ``sum_k sqrt(alpha_k) |e_k>`` on ``mix`` (a unary loader,
    RBS depth ``ceil(log2 K)``); ``V(x)`` loads ``|x>`` on ``data``; then ``U_k`` acts on
    ``data`` controlled on ``mix[k]``. The joint state is
    ``sum_k sqrt(alpha_k) |e_k> U_k |x>``, so tracing out ``mix`` leaves exactly
    ``rho = sum_k alpha_k U_k |x><x| U_k^dagger`` (eq. 1) on ``data``, with no post-selection.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each, parameterised or bound.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries (non-negative, sums to 1; not renormalised).
        Zeros are allowed.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits. None: ``|x> = |0...0>``.

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits: register ``"mix"`` (qubits ``0 .. K-1``) then ``"data"``
        (qubits ``K .. K+n-1``); ``metadata["alpha"]`` holds ``alpha``.

    Raises
    ------
    TypeError
        If ``sub_unitaries`` is not a sequence of circuits or ``loader`` not a circuit.
    ValueError
        For ``K = 0``, sub-unitaries of different widths, ``alpha`` of the wrong length or
        off the simplex, a loader of the wrong width, or clashing parameter names.

    Examples
    --------
    >>> from qdensity.ansatze import pyramid, round_robin
    >>> qc = deterministic_circuit([pyramid(4, parameter_prefix="a"),
    ...                             round_robin(4, parameter_prefix="b")], [0.25, 0.75])
    >>> [r.name for r in qc.qregs], qc.num_parameters
    (['mix', 'data'], 12)
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    loader = _check_loader(loader, circuits[0].num_qubits)
    qc, mix, data = _mix_and_data(circuits, arr, loader, "density_deterministic")
    for k, circ in enumerate(circuits):
        _append_controlled_circuit(qc, mix[k], list(data), circ)
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER}
    return qc


def lcu_circuit(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> QuantumCircuit:
    """The LCU QNN of Fig. 1a: Fig. 1b followed by ``Load(sqrt(alpha))^dagger`` on ``mix``.

    Projecting ``mix`` onto ``|0...0>`` applies ``<0| Load^dagger = sum_k sqrt(alpha_k) <e_k|``
    to ``sum_k sqrt(alpha_k) |e_k> U_k |x>``, leaving ``A |x> = sum_k alpha_k U_k |x>`` on
    ``data``. Success (``mix`` measures all zeros) has probability ``||A |x>||^2``
    (:func:`lcu_success_probability`); the post-selected state is ``A|x> / ||A|x>||``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`deterministic_circuit`.

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits, registers ``"mix"`` then ``"data"``; ``metadata["postselect"]``
        is ``{"mix": 0}``.

    Examples
    --------
    >>> from qdensity.ansatze import pyramid
    >>> qc = lcu_circuit([pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")],
    ...                  [0.5, 0.5])
    >>> qc.num_qubits
    5
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    qc = deterministic_circuit(circuits, arr, loader)
    mix = qc.qregs[0]
    _append_circuit(qc, distribution_loader(arr).inverse(), list(mix))
    qc.name = "density_lcu"
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER, "postselect": {"mix": 0}}
    return qc


def _bound(circuit: QuantumCircuit, name: str) -> QuantumCircuit:
    if circuit.parameters:
        names = ", ".join(p.name for p in list(circuit.parameters)[:5])
        raise ValueError(
            f"{name} has {circuit.num_parameters} unbound parameters ({names}, ...); bind them "
            "with assign_parameters before an exact simulation"
        )
    return circuit


def _data_statevector(data_state, width: int) -> Statevector:
    if data_state is None:
        return Statevector.from_label("0" * width)
    if isinstance(data_state, QuantumCircuit):
        _check_loader(data_state, width)
        return Statevector(_bound(data_state, "data_state"))
    if isinstance(data_state, Statevector):
        if data_state.num_qubits != width:
            raise ValueError(
                f"data_state must be a state of the {width} data qubits, got "
                f"{data_state.num_qubits} qubits"
            )
        return data_state
    raise TypeError(
        "data_state must be a Statevector, a loader QuantumCircuit or None, got "
        f"{type(data_state).__name__}"
    )


def lcu_success_probability(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    data_state: Statevector | QuantumCircuit | None = None,
) -> float:
    """Exact post-selection probability of the LCU QNN: ``||sum_k alpha_k U_k |x>||^2``.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        Bound sub-unitaries on ``n`` qubits.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    data_state : Statevector, QuantumCircuit or None
        ``|x>``: a state of ``n`` qubits, a bound loader circuit ``V(x)``, or None for
        ``|0...0>``.

    Returns
    -------
    float
        In ``[0, 1]`` (by the triangle inequality, ``||A|x>|| <= sum_k alpha_k = 1``).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> u0, u1 = QuantumCircuit(1), QuantumCircuit(1)
    >>> _ = u1.x(0)
    >>> round(lcu_success_probability([u0, u1], [0.5, 0.5]), 6)
    0.5
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    x = _data_statevector(data_state, circuits[0].num_qubits).data
    out = np.zeros_like(x, dtype=complex)
    for k, (a, circ) in enumerate(zip(arr, circuits, strict=True)):
        out += a * (Operator(_bound(circ, f"sub_unitaries[{k}]")).data @ x)
    return float(np.vdot(out, out).real)


def lcu_postselected_state(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> Statevector:
    """Post-selected data state of :func:`lcu_circuit`, from an exact statevector simulation.

    Simulates the LCU circuit, projects ``mix`` onto ``|0...0>`` and normalises:
    ``sum_k alpha_k U_k |x> / ||sum_k alpha_k U_k |x>||``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`lcu_circuit`, all bound.

    Returns
    -------
    Statevector
        On the ``n`` data qubits, unit norm.

    Raises
    ------
    ValueError
        If a circuit has unbound parameters, or the success probability is below ``1e-12``
        (the post-selected state is then undefined).
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    for k, circ in enumerate(circuits):
        _bound(circ, f"sub_unitaries[{k}]")
    if loader is not None:
        _bound(check_circuit(loader, "loader"), "loader")
    qc = lcu_circuit(circuits, arr, loader)
    num_mix = len(circuits)
    amplitudes = Statevector(qc).data[:: 2**num_mix]  # entries with mix = 0...0
    probability = float(np.vdot(amplitudes, amplitudes).real)
    if probability < 1e-12:
        raise ValueError(
            f"the LCU success probability is {probability:.3g} (sum_k alpha_k U_k |x> vanishes); "
            "the post-selected state is undefined"
        )
    return Statevector(amplitudes / math.sqrt(probability))


def hw_generative_circuit(
    sub_unitaries: Sequence[QuantumCircuit], alpha, start_qubit: int = 0
) -> QuantumCircuit:
    """Generative density QNN for Hamming-weight-preserving sub-unitaries (Fig. 13b, Supp. I.3).

    No data loader (``V(x) = 1``). ``mix`` holds ``sum_k sqrt(alpha_k)|e_k>``; for each
    ``k``: ``U_k^dagger`` on ``data``, ``CNOT(mix[k] -> data[start_qubit])``, ``U_k`` on
    ``data``. On ``|0...0>`` a HW-preserving ``U_k`` is a phase, so the pair ``U_k^dagger,
    U_k`` cancels unless the CNOT fired; in branch ``k`` the data ends in
    ``U_k |e_s>`` (up to a phase), so the data marginal is
    ``sum_k alpha_k U_k |e_s><e_s| U_k^dagger`` with ``s = start_qubit``. No controlled
    sub-unitaries are needed: ``K`` CNOTs replace them.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        Hamming-weight-preserving ``U_k`` on ``n`` qubits (checked with
        :func:`qdensity.analysis.is_hamming_weight_preserving`).
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    start_qubit : int
        Data qubit ``s`` that the CNOTs excite (unary basis state ``|e_s>``, statevector
        entry ``2**s``).

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits, registers ``"mix"`` then ``"data"``.

    Raises
    ------
    ValueError
        If a sub-unitary is not Hamming-weight preserving or ``start_qubit`` is out of range.

    Examples
    --------
    >>> from qdensity.ansatze import pyramid
    >>> qc = hw_generative_circuit([pyramid(4, parameter_prefix="a"),
    ...                             pyramid(4, parameter_prefix="b")], [0.5, 0.5])
    >>> qc.count_ops()["cx"]
    2
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    n = circuits[0].num_qubits
    start = check_positive_int(start_qubit, "start_qubit", minimum=0)
    if start >= n:
        raise ValueError(f"start_qubit must be in [0, {n - 1}] (a data qubit), got {start}")
    for k, circ in enumerate(circuits):
        if not is_hamming_weight_preserving(circ):
            raise ValueError(
                f"sub_unitaries[{k}] ({circ.name!r}) is not Hamming-weight preserving; the "
                "circuit of Fig. 13b needs HW-preserving sub-unitaries (RBS, FBS, rz, rzz, ...)"
            )
    qc, mix, data = _mix_and_data(circuits, arr, None, "density_hw_generative")
    for k, circ in enumerate(circuits):
        _append_circuit(qc, circ.inverse(), list(data))
        qc.cx(mix[k], data[start])
        _append_circuit(qc, circ, list(data))
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER, "start_qubit": start}
    return qc


# --------------------------------------------------------------------------------------
# Convenience
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PreparationCircuits:
    """The three preparations of one density QNN (Fig. 1a, b, c), validated once.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits.

    Examples
    --------
    >>> from qdensity.ansatze import pyramid
    >>> prep = PreparationCircuits([pyramid(3, parameter_prefix="a"),
    ...                             pyramid(3, parameter_prefix="b")], [0.5, 0.5])
    >>> sorted(prep.prepare_all())
    ['deterministic', 'lcu', 'randomised']
    """

    sub_unitaries: tuple[QuantumCircuit, ...]
    alpha: np.ndarray
    loader: QuantumCircuit | None = None
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        circuits = tuple(_check_sub_unitaries(self.sub_unitaries))
        object.__setattr__(self, "sub_unitaries", circuits)
        object.__setattr__(self, "alpha", _check_alpha(self.alpha, len(circuits)))
        object.__setattr__(self, "loader", _check_loader(self.loader, circuits[0].num_qubits))
        named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
        if self.loader is not None:
            named.append(("loader", self.loader))
        _check_parameter_names(named)

    @property
    def num_sub_unitaries(self) -> int:
        """``K``."""
        return len(self.sub_unitaries)

    @property
    def num_data_qubits(self) -> int:
        """``n``."""
        return self.sub_unitaries[0].num_qubits

    @property
    def randomised(self) -> list[QuantumCircuit]:
        """Fig. 1c circuits (:func:`randomised_circuits`)."""
        if "randomised" not in self._cache:
            self._cache["randomised"] = randomised_circuits(self.sub_unitaries, self.loader)
        return self._cache["randomised"]

    @property
    def deterministic(self) -> QuantumCircuit:
        """Fig. 1b circuit (:func:`deterministic_circuit`)."""
        if "deterministic" not in self._cache:
            self._cache["deterministic"] = deterministic_circuit(
                self.sub_unitaries, self.alpha, self.loader
            )
        return self._cache["deterministic"]

    @property
    def lcu(self) -> QuantumCircuit:
        """Fig. 1a circuit (:func:`lcu_circuit`)."""
        if "lcu" not in self._cache:
            self._cache["lcu"] = lcu_circuit(self.sub_unitaries, self.alpha, self.loader)
        return self._cache["lcu"]

    def prepare_all(self) -> dict[str, QuantumCircuit | list[QuantumCircuit]]:
        """``{"randomised": [K circuits], "deterministic": circuit, "lcu": circuit}``."""
        return {
            "randomised": self.randomised,
            "deterministic": self.deterministic,
            "lcu": self.lcu,
        }


def prepare_all(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> dict[str, QuantumCircuit | list[QuantumCircuit]]:
    """All three preparations of Fig. 1: ``{"randomised", "deterministic", "lcu"}``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`deterministic_circuit`.

    Returns
    -------
    dict
        ``"randomised"``: list of ``K`` circuits (Fig. 1c); ``"deterministic"``: one circuit
        (Fig. 1b); ``"lcu"``: one circuit (Fig. 1a).

    Examples
    --------
    >>> from qdensity.ansatze import round_robin
    >>> out = prepare_all([round_robin(4, parameter_prefix="a")], [1.0])
    >>> len(out["randomised"]), out["lcu"].num_qubits
    (1, 5)
    """
    return PreparationCircuits(sub_unitaries, alpha, loader).prepare_all()

