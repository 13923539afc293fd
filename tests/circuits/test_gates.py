"""Oracle tests for the RBS and FBS gates (paper eq. 8, Supp. E eq. 24-25).

Every expected matrix is built here, independently of ``qdensity.circuits.gates``: the paper's 4 x 4
matrix, ``expm(-i theta Q)`` with ``Q`` assembled from dense Pauli matrices, Qiskit's
``XXPlusYYGate``, parity projectors for FBS, and for circuits of FBS gates the k-th compound
matrix (all k x k minors by numpy determinants) of the unary matrix of the same circuit with RBS
gates. Qiskit's convention: qubit 0 is the rightmost Kronecker factor.
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
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.circuit.library import XXPlusYYGate
from qiskit.quantum_info import Operator, Statevector
from qiskit_aer import AerSimulator
from scipy.linalg import expm

from qdensity.circuits.ansatze import butterfly, round_robin
from qdensity.circuits.gates import FBSGate, RBSGate, fbs_matrix, rbs_matrix

CZ_BASIS = ["cz", "rz", "sx", "x"]
CX_BASIS = ["cx", "rz", "sx", "x"]

I2 = np.eye(2, dtype=complex)
X = np.array([[0, 1], [1, 0]], dtype=complex)
Y = np.array([[0, -1j], [1j, 0]], dtype=complex)
Z = np.diag([1.0, -1.0]).astype(complex)

angles = st.floats(min_value=-2 * math.pi, max_value=2 * math.pi, allow_nan=False)


def dense(ops: dict[int, np.ndarray], n: int) -> np.ndarray:
    """Tensor product with ``ops[q]`` on qubit ``q`` (identity elsewhere), qubit 0 rightmost."""
    return reduce(np.kron, [ops.get(q, I2) for q in reversed(range(n))])


def paper_rbs(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=complex)


def rbs_generator(i: int, j: int, n: int) -> np.ndarray:
    """``Q = (X_i Y_j - Y_i X_j) / 2``, i.e. ``(Y (x) X - X (x) Y) / 2`` in Qiskit's
    little-endian ordering of the pair ``(i, j)`` (the ``Y`` factor on qubit ``j``)."""
    return (dense({i: X, j: Y}, n) - dense({i: Y, j: X}, n)) / 2


def fbs_oracle(theta: float, m: int) -> np.ndarray:
    """FBS on m contiguous qubits: ``Pi_even RBS_{0,m-1}(theta) + Pi_odd RBS_{0,m-1}(-theta)``,
    with ``Pi_even/odd = (I +- Z_1 ... Z_{m-2}) / 2`` the inner-parity projectors."""
    q = rbs_generator(0, m - 1, m)
    parity = dense({k: Z for k in range(1, m - 1)}, m)
    eye = np.eye(2**m)
    even, odd = (eye + parity) / 2, (eye - parity) / 2
    return even @ expm(-1j * theta * q) + odd @ expm(1j * theta * q)


def weight(b: int) -> int:
    return bin(b).count("1")


def off_weight_blocks(mat: np.ndarray) -> float:
    """Largest entry connecting basis states of different Hamming weight."""
    w = np.array([weight(b) for b in range(mat.shape[0])])
    return float(np.abs(mat[w[:, None] != w[None, :]]).max(initial=0.0))


# ------------------------------------------------------------------------------------- RBS


@settings(max_examples=20, deadline=None)
@given(theta=angles)
def test_rbs_matrix_is_the_papers(theta):
    expected = paper_rbs(theta)
    qc = QuantumCircuit(2)
    qc.append(RBSGate(theta), [0, 1])
    np.testing.assert_allclose(Operator(RBSGate(theta)).data, expected, atol=1e-12)
    np.testing.assert_allclose(Operator(qc).data, expected, atol=1e-12)
    np.testing.assert_allclose(rbs_matrix(theta), expected, atol=1e-15)
    np.testing.assert_allclose(RBSGate(theta).to_matrix(), expected, atol=1e-15)


@settings(max_examples=20, deadline=None)
@given(theta=angles)
def test_rbs_equals_xx_plus_yy(theta):
    np.testing.assert_allclose(
        Operator(RBSGate(theta)).data, Operator(XXPlusYYGate(2 * theta, math.pi / 2)).data,
        atol=1e-12,
    )


@settings(max_examples=20, deadline=None)
@given(theta=angles)
def test_rbs_is_exp_of_generator(theta):
    np.testing.assert_allclose(
        Operator(RBSGate(theta)).data, expm(-1j * theta * rbs_generator(0, 1, 2)), atol=1e-12
    )


def test_rbs_generator_spectrum():
    np.testing.assert_allclose(np.linalg.eigvalsh(rbs_generator(0, 1, 2)), [-1, 0, 0, 1],
                               atol=1e-14)


@settings(max_examples=20, deadline=None)
@given(theta=angles)
def test_rbs_definition_matches_matrix(theta):
    gate = RBSGate(theta)
    assert set(gate.definition.count_ops()) <= {"h", "cz", "ry"}
    assert gate.definition.count_ops()["cz"] == 2
    np.testing.assert_allclose(Operator(gate.definition).data, paper_rbs(theta), atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(theta=angles)
def test_rbs_inverse(theta):
    gate = RBSGate(theta)
    inv = gate.inverse()
    assert isinstance(inv, RBSGate)
    np.testing.assert_allclose(Operator(inv).data @ Operator(gate).data, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(Operator(inv.definition).data, paper_rbs(theta).T, atol=1e-12)


def test_rbs_inverse_of_parameterised_gate():
    p = Parameter("p")
    qc = QuantumCircuit(2)
    qc.append(RBSGate(p), [0, 1])
    both = qc.compose(qc.inverse()).assign_parameters([0.81])
    np.testing.assert_allclose(Operator(both).data, np.eye(4), atol=1e-12)


@settings(max_examples=10, deadline=None)
@given(theta=angles, pair=st.sampled_from([(0, 1), (2, 0), (1, 3), (3, 2)]))
def test_rbs_preserves_hamming_weight_on_any_pair(theta, pair):
    qc = QuantumCircuit(4)
    qc.append(RBSGate(theta), list(pair))
    mat = Operator(qc).data
    assert off_weight_blocks(mat) < 1e-12
    np.testing.assert_allclose(mat, expm(-1j * theta * rbs_generator(*pair, 4)), atol=1e-12)


@pytest.mark.parametrize("level", [1, 2, 3])
@pytest.mark.parametrize("basis,two_qubit", [(CZ_BASIS, "cz"), (CX_BASIS, "cx")])
def test_rbs_transpiles_to_two_entanglers(level, basis, two_qubit):
    theta = 0.4123
    qc = QuantumCircuit(2)
    qc.append(RBSGate(theta), [0, 1])
    out = transpile(qc, basis_gates=basis, optimization_level=level, seed_transpiler=1)
    ops = out.count_ops()
    assert set(ops) <= set(basis)
    assert ops[two_qubit] == 2
    assert Operator.from_circuit(out).equiv(Operator(paper_rbs(theta)), atol=1e-9)
    # a free angle transpiles to the same count
    p = Parameter("p")
    free = QuantumCircuit(2)
    free.append(RBSGate(p), [0, 1])
    out = transpile(free, basis_gates=basis, optimization_level=level, seed_transpiler=1)
    assert out.count_ops()[two_qubit] == 2
    assert Operator.from_circuit(out.assign_parameters([theta])).equiv(
        Operator(paper_rbs(theta)), atol=1e-9)


@pytest.mark.parametrize("basis", [CZ_BASIS, CX_BASIS])
def test_rbs_transpiles_at_level_zero_and_runs_on_aer(basis):
    theta = -1.234
    qc = QuantumCircuit(3)
    qc.x(0)
    qc.append(RBSGate(theta), [0, 2])
    out = transpile(qc, basis_gates=basis, optimization_level=0)
    assert set(out.count_ops()) <= set(basis)
    assert Operator.from_circuit(out).equiv(Operator(qc), atol=1e-9)
    out.save_statevector()
    sv = np.asarray(AerSimulator(method="statevector").run(out).result().get_statevector())
    expected = np.zeros(8)
    expected[1], expected[4] = math.cos(theta), math.sin(theta)
    assert abs(abs(np.vdot(expected, sv)) - 1) < 1e-9


@settings(max_examples=15, deadline=None)
@given(
    theta=angles,
    pair=st.sampled_from([(0, 1), (1, 0), (0, 3), (3, 1), (2, 0)]),
    seed=st.integers(0, 2**16),
)
def test_rbs_rotates_unary_amplitudes_by_plus_theta(theta, pair, seed):
    n = 4
    y = np.random.default_rng(seed).normal(size=n)
    y /= np.linalg.norm(y)
    psi = np.zeros(2**n, dtype=complex)
    psi[[2**k for k in range(n)]] = y
    qc = QuantumCircuit(n)
    i, j = pair
    qc.append(RBSGate(theta), [i, j])
    out = Statevector(psi).evolve(qc).data
    c, s = math.cos(theta), math.sin(theta)
    expected = y.copy()
    expected[i], expected[j] = c * y[i] - s * y[j], s * y[i] + c * y[j]
    np.testing.assert_allclose(out[[2**k for k in range(n)]], expected, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(out), 1.0, atol=1e-12)


# ------------------------------------------------------------------------------------- FBS


@pytest.mark.parametrize("m", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("theta", [0.3, -1.1, 2.7])
def test_fbs_matrix_and_definition_match_parity_oracle(m, theta):
    expected = fbs_oracle(theta, m)
    gate = FBSGate(theta, m)
    np.testing.assert_allclose(Operator(gate.definition).data, expected, atol=1e-12)
    np.testing.assert_allclose(Operator(gate).data, expected, atol=1e-12)
    np.testing.assert_allclose(fbs_matrix(theta, m), expected, atol=1e-12)
    assert off_weight_blocks(expected) < 1e-12


def test_fbs_on_two_qubits_is_rbs():
    np.testing.assert_allclose(Operator(FBSGate(0.77, 2)).data, paper_rbs(0.77), atol=1e-12)


@pytest.mark.parametrize("m", [3, 4, 5])
def test_fbs_inverse(m):
    gate = FBSGate(0.913, m)
    inv = gate.inverse()
    assert isinstance(inv, FBSGate) and inv.num_qubits == m
    np.testing.assert_allclose(Operator(inv).data @ Operator(gate).data, np.eye(2**m),
                               atol=1e-12)
    np.testing.assert_allclose(Operator(inv.definition).data, fbs_oracle(-0.913, m), atol=1e-12)


@pytest.mark.parametrize("m", [3, 4, 5, 6])
def test_fbs_equals_rbs_on_unary_inputs(m):
    theta = 0.61
    fbs, rbs = fbs_oracle(theta, m), expm(-1j * theta * rbs_generator(0, m - 1, m))
    unary = [2**k for k in range(m)]
    np.testing.assert_allclose(fbs[:, unary], rbs[:, unary], atol=1e-12)


@pytest.mark.parametrize("m", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("level", [0, 1, 2, 3])
@pytest.mark.parametrize("basis", [CZ_BASIS, CX_BASIS])
def test_fbs_transpiles_at_every_level(m, level, basis):
    theta = 1.3
    qc = QuantumCircuit(m)
    qc.append(FBSGate(theta, m), list(range(m)))
    out = transpile(qc, basis_gates=basis, optimization_level=level, seed_transpiler=3)
    assert set(out.count_ops()) <= set(basis)
    assert Operator.from_circuit(out).equiv(Operator(fbs_oracle(theta, m)), atol=1e-9)


def test_fbs_width_errors():
    with pytest.raises(ValueError, match="num_qubits"):
        FBSGate(0.1, 1)
    with pytest.raises(TypeError, match="num_qubits"):
        FBSGate(0.1, 3.0)
    with pytest.raises(TypeError, match="num_qubits"):
        fbs_matrix(0.1, True)


# ---------------------------------------------------------------------- compound oracle


def unary_matrix(op: np.ndarray, n: int) -> np.ndarray:
    """The n x n block of ``op`` on unary states (entry ``2**a, 2**b``)."""
    idx = [2**k for k in range(n)]
    block = op[np.ix_(idx, idx)]
    assert np.abs(block.imag).max() < 1e-12
    return block.real


def compound(mat: np.ndarray, k: int) -> np.ndarray:
    """k-th compound matrix: all k x k minors, rows/columns k-subsets in lexicographic order."""
    subsets = list(combinations(range(mat.shape[0]), k))
    return np.array([[np.linalg.det(mat[np.ix_(s, t)]) for t in subsets] for s in subsets])


CASES = [("round_robin", round_robin, n) for n in (4, 5, 6)] + [("butterfly", butterfly, 4),
                                                               ("butterfly", butterfly, 8)]


@pytest.mark.parametrize("name,builder,n", CASES)
def test_fbs_circuit_acts_as_compound_of_rbs_circuit(name, builder, n):
    rbs_qc, fbs_qc = builder(n), builder(n, gate="fbs")
    assert "fbs" in fbs_qc.count_ops() and "fbs" not in rbs_qc.count_ops()
    rng = np.random.default_rng(n)
    for _ in range(2):
        values = rng.uniform(-math.pi, math.pi, rbs_qc.num_parameters)
        orth = unary_matrix(Operator(rbs_qc.assign_parameters(values)).data, n)
        np.testing.assert_allclose(orth.T @ orth, np.eye(n), atol=1e-12)
        u_fbs = Operator(fbs_qc.assign_parameters(values)).data
        assert off_weight_blocks(u_fbs) < 1e-12
        for k in (1, 2, 3):
            idx = [sum(2**i for i in s) for s in combinations(range(n), k)]
            np.testing.assert_allclose(u_fbs[np.ix_(idx, idx)], compound(orth, k), atol=1e-11,
                                       err_msg=f"{name}({n}) weight {k}")
