"""Circuits in other tools: PennyLane and OpenQASM 2/3 conversions of every builder are exact.

Oracles: ``qiskit.quantum_info.Statevector`` / ``Operator`` of the builders' own circuits (RBS
and FBS through their matrices, never their definitions), central finite differences of those
statevectors, the paper's RBS matrix (eq. 8), and the files as ``qiskit.qasm2`` and
``qiskit_qasm3_import`` read them back. Every builder of ``qdensity build`` (loaders, ansätze,
the deterministic and LCU preparations, a commuting-generator gradient circuit from its plan, the
tomography circuits) is converted.
"""

from __future__ import annotations

import re

import numpy as np
import pennylane as qml
import pytest
import qiskit_qasm3_import
from qiskit import QuantumCircuit, qasm2, qasm3
from qiskit.circuit import Parameter
from qiskit.circuit.library import XXPlusYYGate, get_standard_gate_name_mapping
from qiskit.quantum_info import Operator, SparsePauliOp, Statevector

from qdensity.circuits.ansatze.registry import FAMILIES
from qdensity.circuits.gates import FBSGate, RBSGate, rbs_matrix
from qdensity.circuits.interop import PORTABLE_GATES, standard_gates, to_pennylane
from qdensity.cli._builders import BUILDERS, build_circuit

NAMES = list(BUILDERS)
#: The smallest size each registered family builds (the registry's, by command name).
_LOWEST = {f.command_name: f.min_qubits for f in FAMILIES.values()}
#: Sizes that give a non-trivial circuit of every builder (butterfly: a power of two).
SIZE = {name: max(4, _LOWEST.get(name, 2)) for name in NAMES} | {"reuploading": 2}
TOL = 1e-9


def _unitary_part(circuit: QuantumCircuit) -> QuantumCircuit:
    return circuit.remove_final_measurements(inplace=False)


def _random_product(num_qubits: int, seed: int) -> QuantumCircuit:
    """A generic product input (``ry``, ``rz`` on every qubit): every amplitude nonzero, so a
    swapped qubit order or a wrong sign cannot hide behind ``|0...0>``."""
    rng = np.random.default_rng(seed)
    qc = QuantumCircuit(num_qubits)
    for q in range(num_qubits):
        qc.ry(rng.uniform(0.3, 2.8), q)
        qc.rz(rng.uniform(-3.0, 3.0), q)
    return qc


def _builder_case(name: str, seed: int = 7):
    """(symbolic circuit with a random product input in front, its parameter values)."""
    body = _unitary_part(BUILDERS[name](SIZE[name]))
    circuit = _random_product(body.num_qubits, seed).compose(body)
    values = np.random.default_rng(seed).uniform(-np.pi, np.pi, circuit.num_parameters)
    return circuit, values


def _qiskit_order(state, num_qubits: int) -> np.ndarray:
    """A PennyLane state on wires ``0..n-1`` (wire 0 most significant) in Qiskit's order."""
    axes = list(range(num_qubits))[::-1]
    return np.asarray(state).reshape([2] * num_qubits).transpose(axes).reshape(-1)


def _pennylane_state(circuit: QuantumCircuit, values) -> np.ndarray:
    qfunc = to_pennylane(circuit)
    n = circuit.num_qubits

    @qml.qnode(qml.device("default.qubit", wires=n))
    def run():
        qfunc(values)
        return qml.state()

    return _qiskit_order(run(), n)


def _bound(circuit: QuantumCircuit, values) -> QuantumCircuit:
    return circuit.assign_parameters(values) if circuit.num_parameters else circuit


# ------------------------------------------------------------------ the angle map of XXPlusYY


@pytest.mark.parametrize("theta", [0.37, -1.9, 2.8])
@pytest.mark.parametrize("qubits", [(0, 1), (2, 0), (1, 2)])
def test_rbs_is_xx_plus_yy_with_doubled_angle_and_beta_pi_over_two(theta, qubits):
    rbs = QuantumCircuit(3)
    rbs.append(RBSGate(theta), list(qubits))
    xy = QuantumCircuit(3)
    xy.append(XXPlusYYGate(2 * theta, np.pi / 2), list(qubits))
    np.testing.assert_allclose(Operator(xy).data, Operator(rbs).data, atol=1e-12)
    two = QuantumCircuit(2)
    two.append(XXPlusYYGate(2 * theta, np.pi / 2), [0, 1])
    np.testing.assert_allclose(Operator(two).data, rbs_matrix(theta), atol=1e-12)


# ------------------------------------------------------------------ standard_gates


@pytest.mark.parametrize("name", NAMES)
def test_standard_gates_keeps_operator_parameters_and_measurements(name):
    raw = BUILDERS[name](SIZE[name])
    out = standard_gates(raw)
    names = set(out.count_ops())
    assert names <= PORTABLE_GATES | {"measure", "barrier"}, names - PORTABLE_GATES
    standard = get_standard_gate_name_mapping()
    assert all(isinstance(i.operation, type(standard[i.operation.name])) for i in out.data
               if i.operation.name in PORTABLE_GATES)
    assert list(out.parameters) == list(raw.parameters)
    assert [(out.find_bit(i.qubits[0]).index, out.find_bit(i.clbits[0]).index)
            for i in out.data if i.operation.name == "measure"] == [
        (raw.find_bit(i.qubits[0]).index, raw.find_bit(i.clbits[0]).index)
        for i in raw.data if i.operation.name == "measure"]
    values = np.random.default_rng(3).uniform(-np.pi, np.pi, raw.num_parameters)
    want = Operator(_unitary_part(_bound(raw, values))).data
    got = Operator(_unitary_part(_bound(out, values))).data
    np.testing.assert_allclose(got, want, atol=1e-9)  # global phase included


def test_standard_gates_rbs_is_its_two_cz_definition_with_the_parameter_free():
    theta = Parameter("theta")
    qc = QuantumCircuit(3)
    qc.append(FBSGate(theta, 3), [0, 1, 2])
    out = standard_gates(qc)
    assert list(out.parameters) == [theta]
    assert set(out.count_ops()) <= {"h", "cz", "ry", "cx"}
    for value in (0.4, -2.2):
        np.testing.assert_allclose(Operator(out.assign_parameters([value])).data,
                                   Operator(qc.assign_parameters([value])).data, atol=1e-12)


def test_standard_gates_refuses_control_flow_and_undefined_gates():
    from qiskit.circuit import Gate

    qc = QuantumCircuit(1, 1)
    qc.measure(0, 0)
    with qc.if_test((qc.clbits[0], 1)):
        qc.x(0)
    with pytest.raises(ValueError, match="control-flow"):
        standard_gates(qc)
    opaque = QuantumCircuit(2)
    opaque.append(Gate("mystery", 2, []), [0, 1])
    with pytest.raises(ValueError, match="mystery.*no definition"):
        standard_gates(opaque)
    with pytest.raises(TypeError, match="circuit"):
        standard_gates("h q[0];")


# ------------------------------------------------------------------ PennyLane


@pytest.mark.parametrize("name", NAMES)
def test_to_pennylane_gives_the_same_state_for_every_builder(name):
    circuit, values = _builder_case(name)
    want = Statevector(_bound(circuit, values)).data
    got = _pennylane_state(circuit, values)
    fidelity = abs(np.vdot(want, got)) ** 2
    assert fidelity == pytest.approx(1.0, abs=TOL)
    np.testing.assert_allclose(got, want, atol=1e-9)  # the global phase too


@pytest.mark.parametrize("name", ["loader_parallel", "round_robin", "lcu", "equivariant_yy",
                                  "qcnn"])
def test_to_pennylane_matrix_equals_qiskit_operator(name):
    raw = _unitary_part(BUILDERS[name](SIZE[name]))
    values = np.random.default_rng(11).uniform(-np.pi, np.pi, raw.num_parameters)
    n = raw.num_qubits
    qfunc = to_pennylane(raw)
    got = qml.matrix(lambda: qfunc(values), wire_order=list(range(n))[::-1])()
    np.testing.assert_allclose(got, Operator(_bound(raw, values)).data, atol=1e-9)


def test_to_pennylane_on_other_wires():
    circuit, values = _builder_case("pyramid")
    labels = ["a", "b", "c", "d"]

    @qml.qnode(qml.device("default.qubit", wires=labels))
    def run():
        to_pennylane(circuit)(values, wires=labels)
        return qml.state()

    want = Statevector(_bound(circuit, values)).data
    np.testing.assert_allclose(_qiskit_order(run(), 4), want, atol=1e-9)


@pytest.mark.parametrize("name", ["round_robin", "butterfly", "equivariant_xx", "reuploading"])
def test_to_pennylane_gradient_matches_finite_differences_of_qiskit(name):
    circuit, values = _builder_case(name, seed=5)
    n = circuit.num_qubits
    obs = SparsePauliOp.from_sparse_list([("Z", [q], 1.0 + q) for q in range(n)], n)
    qfunc = to_pennylane(circuit)

    @qml.qnode(qml.device("default.qubit", wires=n), diff_method="backprop")
    def expval(x):
        qfunc(x)
        return qml.expval(qml.sum(*[(1.0 + q) * qml.PauliZ(q) for q in range(n)]))

    grad = qml.grad(expval)(qml.numpy.array(values, requires_grad=True))

    def f(x):
        return Statevector(circuit.assign_parameters(x)).expectation_value(obs).real

    h = 1e-5
    fd = [(f(values + h * e) - f(values - h * e)) / (2 * h) for e in np.eye(len(values))]
    assert float(expval(values)) == pytest.approx(f(values), abs=1e-10)
    np.testing.assert_allclose(grad, fd, atol=1e-7)


def test_to_pennylane_refuses_what_it_cannot_convert():
    mid = QuantumCircuit(2, 1)
    mid.h(0)
    mid.measure(0, 0)
    mid.cx(0, 1)
    with pytest.raises(ValueError, match="follows a measurement"):
        to_pennylane(mid)
    reset = QuantumCircuit(1)
    reset.reset(0)
    with pytest.raises(ValueError, match="resets"):
        to_pennylane(reset)
    theta = Parameter("theta")
    square = QuantumCircuit(1)
    square.rx(theta * theta, 0)
    with pytest.raises(ValueError, match="not affine"):
        to_pennylane(square)
    qc = QuantumCircuit(2)
    qc.append(RBSGate(theta), [0, 1])
    qfunc = to_pennylane(qc)
    with pytest.raises(ValueError, match="values must hold"):
        qml.matrix(lambda: qfunc(), wire_order=[1, 0])()
    with pytest.raises(ValueError, match="length 1"):
        qml.matrix(lambda: qfunc([0.1, 0.2]), wire_order=[1, 0])()
    with pytest.raises(ValueError, match="wires must name 2"):
        qml.matrix(lambda: qfunc([0.1], wires=[0]), wire_order=[0])()
    with pytest.raises(ValueError, match="circuit"):
        to_pennylane(QuantumCircuit(0))


# ------------------------------------------------------------------ OpenQASM 2 and 3


def _measure_map(circuit: QuantumCircuit) -> list[tuple[int, int]]:
    return [(circuit.find_bit(i.qubits[0]).index, circuit.find_bit(i.clbits[0]).index)
            for i in circuit.data if i.operation.name == "measure"]


def _assert_same_circuit(loaded: QuantumCircuit, original: QuantumCircuit) -> None:
    """OpenQASM carries no global phase: operators equal up to one phase, measurements equal."""
    assert loaded.num_qubits == original.num_qubits
    assert _measure_map(loaded) == _measure_map(original)
    a = Operator(_unitary_part(loaded)).data
    b = Operator(_unitary_part(original)).data
    k = np.unravel_index(np.argmax(abs(b)), b.shape)
    phase = a[k] / b[k]
    assert abs(abs(phase) - 1) < 1e-9
    np.testing.assert_allclose(a, phase * b, atol=1e-9)


@pytest.mark.parametrize("name", NAMES)
def test_qasm2_round_trip_of_every_builder(name):
    original = build_circuit(name, SIZE[name])
    text = qasm2.dumps(original)
    loaded = qasm2.loads(text, custom_instructions=qasm2.LEGACY_CUSTOM_INSTRUCTIONS)
    _assert_same_circuit(loaded, original)
    # the portable form round-trips too; the file defines no gate of its own (only standard
    # gates that qelib1.inc lacks, such as ryy)
    portable = qasm2.dumps(standard_gates(original))
    assert set(re.findall(r"^gate (\w+)", portable, flags=re.M)) <= PORTABLE_GATES
    _assert_same_circuit(
        qasm2.loads(portable, custom_instructions=qasm2.LEGACY_CUSTOM_INSTRUCTIONS), original)


@pytest.mark.parametrize("name", NAMES)
def test_qasm3_round_trip_of_every_builder(name):
    original = build_circuit(name, SIZE[name])
    _assert_same_circuit(qiskit_qasm3_import.parse(qasm3.dumps(original)), original)
    _assert_same_circuit(qiskit_qasm3_import.parse(qasm3.dumps(standard_gates(original))),
                         original)


@pytest.mark.parametrize("name", ["round_robin", "loader_diagonal", "equivariant_xx"])
def test_qasm3_keeps_parameters_free_through_standard_gates(name):
    raw = _unitary_part(BUILDERS[name](SIZE[name]))
    text = qasm3.dumps(standard_gates(raw))
    loaded = qiskit_qasm3_import.parse(text)
    assert loaded.num_parameters == raw.num_parameters
    values = np.random.default_rng(2).uniform(-np.pi, np.pi, raw.num_parameters)
    # the file declares one input per parameter, in circuit.parameters order (names escaped)
    declared = re.findall(r"^input float\[64\] (\S+);", text, flags=re.M)
    assert len(declared) == raw.num_parameters
    by_name = dict(zip(declared, values, strict=True))
    bound = loaded.assign_parameters({p: by_name[p.name] for p in loaded.parameters})
    _assert_same_circuit(bound, _bound(raw, values))
