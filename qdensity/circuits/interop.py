"""Circuits for other tools: a portable gate set, and an exact PennyLane converter.

qdensity's circuits carry their own gates (``RBSGate``, ``FBSGate``, controlled sub-unitaries,
Pauli evolutions). Qiskit unrolls them through their definitions, but a converter that reads a
custom gate's matrix does not: pennylane-qiskit's ``qml.from_qiskit`` (0.45) turns every gate it
has no name for into ``QubitUnitary(gate.to_matrix())`` without reordering Qiskit's
little-endian matrix, so every RBS/FBS circuit arrives with the wrong state (a unary loader at
fidelity 0.77, ``XXPlusYYGate`` too: it is not in its table). Z expectations alone hide it.

Two routes are exact (docs/guide/interop.md):

* :func:`standard_gates` rewrites a circuit in :data:`PORTABLE_GATES`, Qiskit standard gates
  that OpenQASM 2 (``qelib1.inc`` plus ``qiskit.qasm2.LEGACY_CUSTOM_INSTRUCTIONS``),
  OpenQASM 3 (``stdgates.inc``) and pennylane-qiskit's table all name, each with its own
  operator; free parameters stay free (an RBS angle ``theta`` becomes ``ry(theta)``,
  ``ry(-theta)`` of its two-CZ definition, paper eq. 8).
* :func:`to_pennylane` converts that circuit to a PennyLane quantum function gate by gate,
  needing PennyLane only (no pennylane-qiskit), its angles differentiable by PennyLane.

Wires: Qiskit qubit ``q`` becomes wire ``q``. PennyLane orders a state with wire 0 as the most
significant bit, Qiskit with qubit 0 as the least: ``qml.state()`` on wires ``0..n-1`` is
Qiskit's statevector with the bit order reversed (``qml.matrix(f, wire_order=range(n)[::-1])``
is Qiskit's ``Operator``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from qiskit.circuit import Parameter, ParameterExpression, QuantumCircuit
from qiskit.circuit.library import get_standard_gate_name_mapping

from qdensity.validation import Circuit, validates

__all__ = ["PORTABLE_GATES", "standard_gates", "to_pennylane"]

#: Qiskit gate name -> PennyLane operation name (``"Adjoint(S)"``: the adjoint of ``S``).
#: Every name is a Qiskit standard gate that OpenQASM 2 (with Qiskit's legacy custom
#: instructions), OpenQASM 3 and pennylane-qiskit convert with its own operator.
_PENNYLANE_NAMES: dict[str, str] = {
    "id": "Identity", "x": "PauliX", "y": "PauliY", "z": "PauliZ", "h": "Hadamard",
    "s": "S", "sdg": "Adjoint(S)", "t": "T", "tdg": "Adjoint(T)", "sx": "SX",
    "sxdg": "Adjoint(SX)", "rx": "RX", "ry": "RY", "rz": "RZ", "p": "PhaseShift", "u": "U3",
    "cx": "CNOT", "cy": "CY", "cz": "CZ", "ch": "CH", "swap": "SWAP", "cp": "ControlledPhaseShift",
    "crx": "CRX", "cry": "CRY", "crz": "CRZ", "ccx": "Toffoli", "cswap": "CSWAP",
    "rxx": "IsingXX", "ryy": "IsingYY", "rzz": "IsingZZ",
}

#: The gates :func:`standard_gates` keeps (Qiskit names); every other gate is unrolled
#: through its definition until only these, ``measure``, ``barrier`` and ``reset`` remain.
PORTABLE_GATES: frozenset[str] = frozenset(_PENNYLANE_NAMES)

_KEEP = frozenset({"measure", "barrier", "reset"})
_STANDARD = get_standard_gate_name_mapping()
#: Deepest chain of definitions followed before a gate is refused (a definition that refers
#: back to its own gate would otherwise recurse without end).
_MAX_DEPTH = 64


def _is_portable(op) -> bool:
    """A portable standard gate: its name in :data:`PORTABLE_GATES` *and* Qiskit's own class
    for that name (a custom gate that borrows a standard name, e.g. a ``Gate("h", ...)`` of
    another matrix, is unrolled instead)."""
    std = _STANDARD.get(op.name)
    return op.name in PORTABLE_GATES and std is not None and isinstance(op, type(std))


def _unroll(circuit: QuantumCircuit, out: QuantumCircuit, qubits: list, clbits: list,
            depth: int) -> None:
    """Append ``circuit``'s instructions to ``out`` on ``qubits``/``clbits``, unrolled."""
    out.global_phase += circuit.global_phase
    for inst in circuit.data:
        op = inst.operation
        qs = [qubits[circuit.find_bit(q).index] for q in inst.qubits]
        cs = [clbits[circuit.find_bit(c).index] for c in inst.clbits]
        if op.name in _KEEP or _is_portable(op):
            out.append(op, qs, cs, copy=False)
            continue
        if getattr(op, "blocks", ()):
            raise ValueError(f"circuit holds the control-flow operation {op.name!r}; "
                             "standard_gates converts circuits without control flow")
        definition = op.definition
        if definition is None or depth >= _MAX_DEPTH:
            raise ValueError(f"gate {op.name!r} on qubits {[out.find_bit(q).index for q in qs]}"
                             " has no definition in standard gates; give a circuit whose gates "
                             "define themselves (Gate._define), or transpile it first")
        _unroll(definition, out, qs, cs, depth + 1)


@validates(circuit=Circuit())
def standard_gates(circuit: QuantumCircuit) -> QuantumCircuit:
    """An equivalent circuit of :data:`PORTABLE_GATES` only, its free parameters kept.

    Every gate outside the set (RBS, FBS, controlled sub-unitaries, Pauli evolutions, state
    preparations, custom gates) is replaced by its definition, recursively; gate angles stay
    ``ParameterExpression`` s of the circuit's parameters, so the result has the same
    ``parameters`` in the same order, and binding commutes with the conversion. Measurements,
    resets and barriers are kept; the global phase is carried.

    Parameters
    ----------
    circuit : QuantumCircuit
        Any circuit without control flow; registers, qubit and clbit order are kept.

    Returns
    -------
    QuantumCircuit
        The same unitary (``Operator`` equal, global phase included) and the same measurements,
        on the same qubits. ``RBSGate(theta)`` becomes ``h, h, cz, ry(theta), ry(-theta), cz,
        h, h`` (paper eq. 8 with two CZ).

    Raises
    ------
    ValueError
        For control flow, or a gate without a definition.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.circuit import Parameter
    >>> from qdensity import RBSGate
    >>> from qdensity.circuits.interop import standard_gates
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.append(RBSGate(Parameter("theta")), [0, 1])
    >>> out = standard_gates(qc)
    >>> sorted(out.count_ops().items()), [p.name for p in out.parameters]
    ([('cz', 2), ('h', 4), ('ry', 2)], ['theta'])
    """
    out = circuit.copy_empty_like()
    out.global_phase = 0
    _unroll(circuit, out, list(out.qubits), list(out.clbits), 0)
    return out


@dataclass(frozen=True)
class _Angle:
    """A gate angle ``constant + sum_k coefficient_k * values[index_k]``."""

    constant: float
    terms: tuple[tuple[int, float], ...]

    def __call__(self, values):
        out = self.constant
        for index, coefficient in self.terms:
            out = out + coefficient * values[index]
        return out


def _linear(value, position: dict[Parameter, int], gate: str) -> _Angle:
    """A gate parameter as an affine function of the circuit's parameters (refusing others)."""
    if not isinstance(value, ParameterExpression):
        return _Angle(float(value), ())
    zero = value.bind({p: 0.0 for p in value.parameters})
    terms = []
    for p in sorted(value.parameters, key=lambda q: position[q]):
        grad = value.gradient(p)
        if isinstance(grad, ParameterExpression):
            raise ValueError(f"gate {gate!r} has the angle {value}, not affine in its "
                             "parameters; to_pennylane converts affine angles (bind the others "
                             "first)")
        terms.append((position[p], float(complex(grad).real)))
    return _Angle(float(complex(zero).real), tuple(terms))


def _final_measurements_only(circuit: QuantumCircuit) -> None:
    """Refuse a measurement or reset that a later gate follows on the same qubit."""
    done: set = set()
    for inst in circuit.data:
        name = inst.operation.name
        if name == "reset":
            raise ValueError("circuit resets a qubit; to_pennylane converts unitary circuits "
                             "with final measurements only")
        if name == "measure":
            done.update(inst.qubits)
        elif name != "barrier" and done.intersection(inst.qubits):
            raise ValueError(f"gate {name!r} follows a measurement on the same qubit; "
                             "to_pennylane converts unitary circuits with final measurements "
                             "only")


@validates(circuit=Circuit(min_qubits=1))
def to_pennylane(circuit: QuantumCircuit) -> Callable:
    """A PennyLane quantum function applying ``circuit``'s unitary, gate for gate.

    The circuit is first rewritten by :func:`standard_gates`; each portable gate becomes the
    PennyLane operation with the same operator (Qiskit qubit ``q`` on wire ``wires[q]``), the
    global phase a ``qml.GlobalPhase``. Final measurements are dropped: the caller returns the
    measurements it wants. Only PennyLane is needed (not pennylane-qiskit).

    Parameters
    ----------
    circuit : QuantumCircuit
        ``n`` qubits and ``P`` free parameters (``P >= 0``), each gate angle affine in them
        (as every qdensity builder's); measurements only at the end, no resets.

    Returns
    -------
    callable
        ``qfunc(values=None, wires=None)``: ``values`` of shape ``(P,)`` in
        ``circuit.parameters`` order (any array PennyLane accepts, so autograd / torch / jax
        differentiate through it; required when ``P > 0``), ``wires`` a sequence of ``n``
        wire labels (default ``range(n)``). Call it inside a QNode or ``qml.matrix``. With
        wires ``0..n-1``, ``qml.state()`` is Qiskit's ``Statevector`` with the bit order
        reversed.

    Raises
    ------
    ImportError
        Without PennyLane (``pip install "qdensity[interop]"``).
    ValueError
        For a mid-circuit measurement, a reset, control flow or a non-affine angle.

    Examples
    --------
    >>> import numpy as np
    >>> import pennylane as qml
    >>> from qiskit import QuantumCircuit
    >>> from qdensity import RBSGate
    >>> from qdensity.circuits.interop import to_pennylane
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.x(0)
    >>> _ = qc.append(RBSGate(0.3), [0, 1])
    >>> state = qml.QNode(lambda: (to_pennylane(qc)(), qml.state())[1],
    ...                   qml.device("default.qubit", wires=2))()
    >>> # Qiskit's index q0 + 2 q1: |q0=1> -> cos(0.3)|10> + sin(0.3)|01>, read big-endian
    >>> bool(np.allclose(state, [0, np.sin(0.3), np.cos(0.3), 0]))
    True
    """
    try:
        import pennylane as qml
    except ImportError as exc:  # pragma: no cover - the interop extra is installed in CI
        raise ImportError("to_pennylane needs PennyLane: pip install \"qdensity[interop]\""
                          ) from exc
    _final_measurements_only(circuit)
    portable = standard_gates(circuit)
    position = {p: i for i, p in enumerate(circuit.parameters)}
    ops = []
    for inst in portable.data:
        op = inst.operation
        if op.name in _KEEP:
            continue
        name = _PENNYLANE_NAMES[op.name]
        angles = tuple(_linear(v, position, op.name) for v in op.params)
        qubits = tuple(portable.find_bit(q).index for q in inst.qubits)
        ops.append((name, angles, qubits))
    phase = _linear(portable.global_phase, position, "global phase")
    num_qubits, num_parameters = circuit.num_qubits, circuit.num_parameters

    def qfunc(values=None, wires=None):
        if num_parameters and values is None:
            raise ValueError(f"values must hold the circuit's {num_parameters} parameter "
                             "values (circuit.parameters order); got None")
        if values is not None and len(values) != num_parameters:
            raise ValueError(f"values must have length {num_parameters} (circuit.parameters "
                             f"order), got {len(values)}")
        labels = list(range(num_qubits)) if wires is None else list(wires)
        if len(labels) != num_qubits:
            raise ValueError(f"wires must name {num_qubits} wires, got {len(labels)}")
        for name, angles, qubits in ops:
            on = [labels[q] for q in qubits]
            args = [angle(values) for angle in angles]
            if name.startswith("Adjoint("):
                qml.adjoint(getattr(qml, name[8:-1]))(*args, wires=on)
            else:
                getattr(qml, name)(*args, wires=on)
        # Qiskit's global phase g multiplies by exp(i g); qml.GlobalPhase(t) by exp(-i t)
        value = phase(values)
        if phase.terms or not math.isclose(float(value), 0.0, abs_tol=1e-15):
            qml.GlobalPhase(-value, wires=labels)

    return qfunc
