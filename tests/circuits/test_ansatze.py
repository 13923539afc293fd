"""Oracle tests for ``qdensity.analysis`` and the Hamming-weight-preserving ansätze (Fig. 9).

Oracles: layerings worked out by hand for small circuits, ``expm(-i t G)`` with ``G`` assembled
from dense Pauli matrices (qubit 0 the rightmost Kronecker factor), the module docstring's table
of gate counts and depths, the circle method's defining property (every pair once, disjoint
rounds), and finite-difference Jacobians of the unary (Hamming-weight-1) block of ``Operator``.
"""

from __future__ import annotations

import math
from functools import reduce
from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import transpile
from qiskit.circuit import Parameter, ParameterVector, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate, UnitaryGate
from qiskit.quantum_info import Operator, SparsePauliOp
from scipy.linalg import expm

from qdensity.analysis import (
    depth_of_gates,
    instruction_generator,
    is_hamming_weight_preserving,
    moments,
    parameter_of,
)
from qdensity.circuits.ansatze import (
    butterfly,
    hardware_efficient,
    pairs_circuit,
    pyramid,
    round_robin,
    round_robin_pairs,
    x_circuit,
)
from qdensity.circuits.gates import RBSGate

I2 = np.eye(2, dtype=complex)
PAULI = {
    "I": I2,
    "X": np.array([[0, 1], [1, 0]], dtype=complex),
    "Y": np.array([[0, -1j], [1j, 0]], dtype=complex),
    "Z": np.diag([1.0, -1.0]).astype(complex),
}


def dense(ops: dict[int, str], n: int) -> np.ndarray:
    """Pauli string with letter ``ops[q]`` on qubit ``q``; qubit 0 is the rightmost factor."""
    return reduce(np.kron, [PAULI[ops.get(q, "I")] for q in reversed(range(n))])


def qubits_of(circuit: QuantumCircuit, inst) -> tuple[int, ...]:
    return tuple(circuit.find_bit(q).index for q in inst.qubits)


def unary_block(circuit: QuantumCircuit, values) -> np.ndarray:
    n = circuit.num_qubits
    op = Operator(circuit.assign_parameters(values)).data
    idx = [2**k for k in range(n)]
    return op[np.ix_(idx, idx)].real


# --------------------------------------------------------------------------------- moments


def test_moments_hand_made_circuit():
    a, b = Parameter("a"), Parameter("b")
    qc = QuantumCircuit(3, 3)
    qc.h(0)  # layer 0
    qc.rx(a, 1)  # layer 0
    qc.cx(0, 1)  # layer 1
    qc.measure(2, 2)  # skipped, occupies nothing
    qc.x(2)  # layer 0
    qc.h(0)  # layer 2
    qc.barrier(0, 2)  # q2 now waits for layer 3
    qc.ry(b, 2)  # layer 3
    qc.z(1)  # layer 2
    layers = moments(qc)
    names = [[inst.operation.name for inst in layer] for layer in layers]
    assert names == [["h", "rx", "x"], ["cx"], ["h", "z"], ["ry"]]
    for layer in layers:
        used = [q for inst in layer for q in qubits_of(qc, inst)]
        assert len(used) == len(set(used))
    trainable = moments(qc, include_unparameterised=False)
    assert [[inst.operation.name for inst in layer] for layer in trainable] == [["rx", "ry"]]


def test_moments_barrier_synchronises_all_spanned_qubits():
    qc = QuantumCircuit(3)
    qc.x(0)
    qc.x(0)
    qc.barrier()
    qc.x(1)
    qc.x(2)
    layers = moments(qc)
    assert [len(layer) for layer in layers] == [1, 1, 2]
    assert moments(QuantumCircuit(2)) == []


def test_moments_of_hardware_efficient_trainable_layers():
    n, reps = 4, 3
    qc = hardware_efficient(n, reps, rotations=("rx", "ry"))
    layers = moments(qc, include_unparameterised=False)
    assert len(layers) == reps
    params = list(qc.parameters)
    for d, layer in enumerate(layers):
        assert sorted(qubits_of(qc, inst)[0] for inst in layer) == list(range(n))
        assert {parameter_of(inst)[0] for inst in layer} == set(params[d * n:(d + 1) * n])


def test_moments_refuses_non_circuits():
    with pytest.raises(TypeError, match="circuit"):
        moments([1, 2])


# ------------------------------------------------------------------- instruction generator

GENERATOR_CASES = [
    ("rx", [2], {2: "X"}),
    ("ry", [3], {3: "Y"}),
    ("rz", [1], {1: "Z"}),
    ("rxx", [3, 0], {3: "X", 0: "X"}),
    ("ryy", [1, 3], {1: "Y", 3: "Y"}),
    ("rzz", [2, 0], {2: "Z", 0: "Z"}),
    ("rzx", [3, 1], {3: "Z", 1: "X"}),  # Qiskit's RZX: Z on its first qubit, X on the second
]


@settings(max_examples=10, deadline=None)
@given(t=st.floats(-3.0, 3.0, allow_nan=False), case=st.sampled_from(GENERATOR_CASES))
def test_instruction_generator_of_pauli_rotations(t, case):
    name, qubits, letters = case
    qc = QuantumCircuit(4)
    getattr(qc, name)(t, *qubits)
    gen = instruction_generator(qc.data[0], qc)
    assert gen.num_qubits == 4
    expected_gen = dense(letters, 4) / 2
    np.testing.assert_allclose(gen.to_matrix(), expected_gen, atol=1e-14)
    np.testing.assert_allclose(Operator(qc).data, expm(-1j * t * expected_gen), atol=1e-12)


@settings(max_examples=10, deadline=None)
@given(t=st.floats(-3.0, 3.0, allow_nan=False),
       pair=st.sampled_from([(0, 1), (3, 0), (1, 3), (2, 1)]))
def test_instruction_generator_of_rbs(t, pair):
    i, j = pair
    qc = QuantumCircuit(4)
    qc.append(RBSGate(t), [i, j])
    gen = instruction_generator(qc.data[0], qc).to_matrix()
    expected = (dense({i: "X", j: "Y"}, 4) - dense({i: "Y", j: "X"}, 4)) / 2
    np.testing.assert_allclose(gen, expected, atol=1e-14)
    np.testing.assert_allclose(Operator(qc).data, expm(-1j * t * expected), atol=1e-12)
    np.testing.assert_allclose(np.linalg.eigvalsh(expected)[[0, -1]], [-1, 1], atol=1e-14)


@pytest.mark.parametrize(
    "labels,coeffs,qubits",
    [(["XZ"], [0.7], [2, 0]), (["XZ", "YY"], [0.4, -1.3], [3, 1]), (["ZYX"], [-0.25], [1, 3, 0])],
)
def test_instruction_generator_of_pauli_evolution(labels, coeffs, qubits):
    # terms chosen pairwise commuting so that Operator(gate) is exact
    t = 0.83
    op = SparsePauliOp(labels, coeffs)
    qc = QuantumCircuit(4)
    qc.append(PauliEvolutionGate(op, time=t), qubits)
    expected = sum(
        c * dense({qubits[k]: label[::-1][k] for k in range(len(qubits))}, 4)
        for label, c in zip(labels, coeffs, strict=True)
    )
    gen = instruction_generator(qc.data[0], qc).to_matrix()
    np.testing.assert_allclose(gen, expected, atol=1e-14)
    np.testing.assert_allclose(Operator(qc).data, expm(-1j * t * expected), atol=1e-12)


@pytest.mark.parametrize("gate", ["crx", "cry", "crz", "p", "cp", "fbs"])
def test_instruction_generator_of_controlled_rotations_phases_and_fbs(gate):
    """``gate(t) = exp(-i t G)`` exactly (matrix oracle) for the generators issue 16 added."""
    from qdensity.circuits.gates import FBSGate

    t = 0.37
    qc = QuantumCircuit(4)
    if gate == "fbs":
        qc.append(FBSGate(t, 3), [1, 2, 3])
    elif gate == "p":
        qc.p(t, 2)
    else:
        getattr(qc, gate)(t, 3, 1)
    gen = instruction_generator(qc.data[0], qc).to_matrix()
    np.testing.assert_allclose(gen, gen.conj().T, atol=1e-14)
    np.testing.assert_allclose(Operator(qc).data, expm(-1j * t * gen), atol=1e-12)


def test_instruction_generator_errors():
    qc = QuantumCircuit(3)
    qc.h(0)
    with pytest.raises(ValueError, match=r"'h'.*supported: rx, ry, rz.*crx, cry, crz"):
        instruction_generator(qc.data[0], qc)
    qc = QuantumCircuit(2)
    qc.append(PauliEvolutionGate([SparsePauliOp("XX"), SparsePauliOp("ZZ")], time=0.2), [0, 1])
    with pytest.raises(ValueError, match="list"):
        instruction_generator(qc.data[0], qc)


# ------------------------------------------------------------------------------ parameter_of


@settings(max_examples=15, deadline=None)
@given(a=st.floats(-5, 5).filter(lambda v: abs(v) > 1e-3), b=st.floats(-5, 5))
def test_parameter_of_linear_angles(a, b):
    p = Parameter("p")
    qc = QuantumCircuit(2)
    qc.rx(a * p + b, 0)
    qc.append(RBSGate(a * p), [0, 1])
    for inst in qc.data:
        param, coeff = parameter_of(inst)
        assert param == p
        assert coeff == pytest.approx(a, rel=1e-12)


def test_parameter_of_plain_vector_element_and_bound():
    theta = ParameterVector("θ", 2)
    qc = QuantumCircuit(1)
    qc.ry(theta[1], 0)
    qc.rz(0.4, 0)
    qc.h(0)
    assert parameter_of(qc.data[0]) == (theta[1], 1.0)
    assert parameter_of(qc.data[1]) is None
    assert parameter_of(qc.data[2]) is None


def test_parameter_of_errors():
    p, q = Parameter("p"), Parameter("q")
    qc = QuantumCircuit(1)
    qc.rx(p * q, 0)
    qc.rx(p + q, 0)
    qc.rx(p * p, 0)
    qc.u(p, q, 0.1, 0)
    with pytest.raises(ValueError, match="several parameters"):
        parameter_of(qc.data[0])
    with pytest.raises(ValueError, match="several parameters"):
        parameter_of(qc.data[1])
    with pytest.raises(ValueError, match="not linear"):
        parameter_of(qc.data[2])
    with pytest.raises(ValueError, match="several parameterised angles"):
        parameter_of(qc.data[3])


# ------------------------------------------------------------------ Hamming-weight preservation


@pytest.mark.parametrize("builder", [pyramid, x_circuit, round_robin])
def test_hw_preserving_circuits(builder):
    qc = builder(4)
    assert is_hamming_weight_preserving(qc)
    assert is_hamming_weight_preserving(round_robin(5, gate="fbs"))
    op = Operator(qc.assign_parameters(np.linspace(0.1, 1.7, qc.num_parameters))).data
    w = np.array([bin(b).count("1") for b in range(16)])
    assert np.abs(op[w[:, None] != w[None, :]]).max() < 1e-12


def test_hw_preservation_detects_breaking_gates():
    base = pyramid(3)
    with_rx = base.copy()
    with_rx.rx(0.2, 1)
    with_cx = base.copy()
    with_cx.cx(0, 2)
    assert not is_hamming_weight_preserving(with_rx)
    assert not is_hamming_weight_preserving(with_cx)
    # opaque matrices are judged by their block structure
    good, bad = QuantumCircuit(2), QuantumCircuit(2)
    good.append(UnitaryGate(Operator(RBSGate(0.3))), [0, 1])
    bad.append(UnitaryGate(Operator(RBSGate(0.3)).compose(Operator.from_label("XI"))), [0, 1])
    assert is_hamming_weight_preserving(good)
    assert not is_hamming_weight_preserving(bad)


# --------------------------------------------------------------------------------- ansätze


def table(builder: str, n: int) -> tuple[int, int]:
    """(RBS gates, RBS depth) from the module docstring's table."""
    if builder == "pyramid":
        return n * (n - 1) // 2, 2 * n - 3
    if builder == "x_circuit":
        return (2 * n - 3, n - 1) if n % 2 == 0 else (2 * n - 2, n + 1)
    if builder == "butterfly":
        k = int(math.log2(n))
        return n // 2 * k, k
    return n * (n - 1) // 2, (n - 1 if n % 2 == 0 else n)


BUILDERS = {"pyramid": pyramid, "x_circuit": x_circuit, "butterfly": butterfly,
            "round_robin": round_robin}


@pytest.mark.parametrize("name", list(BUILDERS))
@pytest.mark.parametrize("n", range(2, 11))
def test_gate_counts_and_depths_match_table(name, n):
    if name == "butterfly" and n & (n - 1):
        return
    qc = BUILDERS[name](n)
    gates, depth = table(name, n)
    assert qc.num_qubits == n
    assert qc.count_ops() == {"rbs": gates}
    assert qc.num_parameters == gates
    assert len(moments(qc)) == depth
    assert depth_of_gates(qc, ["rbs"]) == depth
    assert qc.depth() == depth
    # parameters follow gate order
    assert [parameter_of(inst)[0] for inst in qc.data] == list(qc.parameters)


@pytest.mark.parametrize("n", range(2, 11))
def test_round_robin_every_pair_once_and_disjoint_rounds(n):
    qc = round_robin(n)
    pairs = [tuple(sorted(qubits_of(qc, inst))) for inst in qc.data]
    assert sorted(pairs) == list(combinations(range(n), 2))
    for layer in moments(qc):
        used = [q for inst in layer for q in qubits_of(qc, inst)]
        assert len(used) == len(set(used))
    rounds = round_robin_pairs(n)
    assert len(rounds) == (n - 1 if n % 2 == 0 else n)
    for rnd in rounds:
        used = [q for pair in rnd for q in pair]
        assert len(used) == len(set(used))
        assert len(rnd) == n // 2


def test_pyramid_and_butterfly_connectivity():
    qc = pyramid(5)
    assert all(abs(a - b) == 1 for a, b in (qubits_of(qc, i) for i in qc.data))
    bf = butterfly(8)
    strides = [[abs(a - b) for a, b in (qubits_of(bf, i) for i in layer)] for layer in moments(bf)]
    assert strides == [[4] * 4, [2] * 4, [1] * 4]


@pytest.mark.parametrize("n", [3, 5, 6, 12])
def test_butterfly_refuses_non_powers_of_two(n):
    with pytest.raises(ValueError, match="num_qubits") as info:
        butterfly(n)
    assert str(n) in str(info.value)


def test_builder_input_errors():
    with pytest.raises(ValueError, match="num_qubits"):
        pyramid(1)
    with pytest.raises(TypeError, match="num_qubits"):
        round_robin(4.0)
    with pytest.raises(ValueError, match="gate"):
        pyramid(4, gate="cnot")
    with pytest.raises(ValueError, match="pair"):
        pairs_circuit(3, [[(0, 3)]])
    with pytest.raises(ValueError, match="pair"):
        pairs_circuit(3, [[(1, 1)]])


@pytest.mark.parametrize("n", [3, 4, 5])
def test_pyramid_parameterises_so_n(n):
    qc = pyramid(n)
    dim = n * (n - 1) // 2
    rng = np.random.default_rng(n)
    theta = rng.uniform(-math.pi, math.pi, dim)
    orth = unary_block(qc, theta)
    np.testing.assert_allclose(orth.T @ orth, np.eye(n), atol=1e-12)
    assert np.linalg.det(orth) == pytest.approx(1.0, abs=1e-12)
    h = 1e-6
    jac = np.empty((n * n, dim))
    for k in range(dim):
        e = np.zeros(dim)
        e[k] = h
        jac[:, k] = ((unary_block(qc, theta + e) - unary_block(qc, theta - e)) / (2 * h)).ravel()
    sv = np.linalg.svd(jac, compute_uv=False)
    assert np.linalg.matrix_rank(jac, tol=1e-6) == dim
    assert sv[dim - 1] > 1e-3


@pytest.mark.parametrize("name", list(BUILDERS))
@pytest.mark.parametrize("basis", [["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"]])
def test_ansatze_transpile_to_basis(name, basis):
    qc = BUILDERS[name](4)
    values = np.linspace(-1.0, 1.3, qc.num_parameters)
    out = transpile(qc, basis_gates=basis, optimization_level=1, seed_transpiler=0)
    assert set(out.count_ops()) <= set(basis)
    assert out.count_ops()[basis[0]] == 2 * qc.num_parameters
    assert Operator.from_circuit(out.assign_parameters(values)).equiv(
        Operator(qc.assign_parameters(values)), atol=1e-9)
