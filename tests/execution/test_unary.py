"""Unary engine against statevector simulation and finite differences (docs/design.md,
"Oracles")."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.quantum_info import Statevector

from qdensity.circuits.ansatze import butterfly, pairs_circuit, pyramid, round_robin, x_circuit
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.execution.unary import (
    UnaryCircuit,
    compile_unary,
    forward,
    jacobian,
    orthogonal_matrix,
    vjp,
)

TOL = 1e-10


# ----------------------------------------------------------------------------- oracles
def unary_statevector(x: np.ndarray) -> Statevector:
    """Oracle input: the dense 2**n vector with x_j at entry 2**j (built directly)."""
    n = len(x)
    psi = np.zeros(2**n, dtype=complex)
    psi[[2**j for j in range(n)]] = x
    return Statevector(psi)


def statevector_output(circuit: QuantumCircuit, x: np.ndarray, values) -> np.ndarray:
    """Unary amplitudes of ``circuit(values)|x>`` by full statevector simulation."""
    n = circuit.num_qubits
    bound = circuit.assign_parameters(values) if circuit.num_parameters else circuit
    out = unary_statevector(x).evolve(bound).data
    unary = [2**j for j in range(n)]
    mask = np.ones(2**n, bool)
    mask[unary] = False
    assert np.abs(out[mask]).max(initial=0.0) < TOL  # stays in the unary subspace
    assert np.abs(out[unary].imag).max() < TOL
    return out[unary].real


def fbs_pairs_circuit(n: int, rng: np.random.Generator) -> QuantumCircuit:
    """Random layers of disjoint non-adjacent pairs, built with FBS gates."""
    layers = []
    for _ in range(3):
        perm = rng.permutation(n)
        pairs = [(int(perm[2 * k]), int(perm[2 * k + 1])) for k in range(n // 2)]
        layers.append([(min(p), max(p)) for p in pairs])
    return pairs_circuit(n, layers, gate="fbs")


FAMILIES = ["pyramid", "x", "butterfly", "round_robin", "fbs_pairs", "fbs_butterfly"]


def build(family: str, n: int, rng: np.random.Generator) -> QuantumCircuit:
    if family == "pyramid":
        return pyramid(n)
    if family == "x":
        return x_circuit(n)
    if family == "round_robin":
        return round_robin(n)
    if family == "butterfly":
        return butterfly(n)
    if family == "fbs_butterfly":
        return butterfly(n, gate="fbs")
    return fbs_pairs_circuit(n, rng)


def shared_circuit() -> QuantumCircuit:
    """Shared parameters, affine angles, reversed qubit order, fixed angles, FBS, barrier."""
    a, b, c = Parameter("a"), Parameter("b"), Parameter("c")
    qc = QuantumCircuit(5)
    qc.append(RBSGate(a), [0, 1])
    qc.append(RBSGate(2 * a + 0.3), [3, 1])
    qc.append(RBSGate(0.7), [2, 4])
    qc.barrier()
    qc.append(FBSGate(-1.5 * b + 0.2, 4), [1, 2, 3, 4])
    qc.append(RBSGate(c), [4, 0])
    qc.append(FBSGate(a - 1.0, 3), [0, 1, 2])
    qc.append(RBSGate(b).inverse(), [2, 3])
    return qc


def unit_rows(rng: np.random.Generator, rows: int, n: int) -> np.ndarray:
    X = rng.normal(size=(rows, n))
    return X / np.linalg.norm(X, axis=1, keepdims=True)


# ----------------------------------------------------------------------------- forward
@settings(max_examples=25, deadline=None)
@given(
    family=st.sampled_from(FAMILIES),
    n=st.integers(2, 10),
    seed=st.integers(0, 2**32 - 1),
)
def test_forward_matches_statevector(family, n, seed):
    rng = np.random.default_rng(seed)
    if "butterfly" in family:
        n = 2 ** int(np.log2(n))
    qc = build(family, n, rng)
    values = rng.uniform(-np.pi, np.pi, qc.num_parameters)
    X = unit_rows(rng, 2, n)
    Y = forward(qc, X, values)
    for x, y in zip(X, Y, strict=True):
        np.testing.assert_allclose(y, statevector_output(qc, x, values), atol=TOL)
    O = orthogonal_matrix(qc, values)
    np.testing.assert_allclose(O @ O.T, np.eye(n), atol=TOL)
    np.testing.assert_allclose(O @ X[0], Y[0], atol=TOL)
    assert np.linalg.det(O) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("family", FAMILIES)
def test_orthogonal_matrix_columns_match_statevector(family):
    rng = np.random.default_rng(7)
    n = 8 if "butterfly" in family else 6
    qc = build(family, n, rng)
    values = rng.uniform(-np.pi, np.pi, qc.num_parameters)
    O = orthogonal_matrix(compile_unary(qc), values)
    for j in range(n):
        np.testing.assert_allclose(O[:, j], statevector_output(qc, np.eye(n)[j], values), atol=TOL)


def test_shared_and_affine_parameters_match_statevector():
    qc = shared_circuit()
    rng = np.random.default_rng(3)
    values = rng.uniform(-2, 2, 3)
    X = unit_rows(rng, 3, 5)
    Y = forward(qc, X, values)
    for x, y in zip(X, Y, strict=True):
        np.testing.assert_allclose(y, statevector_output(qc, x, values), atol=TOL)
    compiled = compile_unary(qc)
    assert isinstance(compiled, UnaryCircuit)
    assert compiled.num_gates == 7 and compiled.num_parameters == 3


def test_per_row_values_and_large_batches():
    qc = pyramid(4)
    rng = np.random.default_rng(11)
    V = rng.uniform(-np.pi, np.pi, (3, qc.num_parameters))
    X = unit_rows(rng, 3, 4)
    Y = forward(qc, X, V)
    for x, v, y in zip(X, V, Y, strict=True):
        np.testing.assert_allclose(y, statevector_output(qc, x, v), atol=TOL)
    # one input under several parameter rows
    Y1 = forward(qc, X[0], V)
    for v, y in zip(V, Y1, strict=True):
        np.testing.assert_allclose(y, statevector_output(qc, X[0], v), atol=TOL)
    # shared values, batch larger than n (matrix-product path) and 1-d input
    big = unit_rows(rng, 9, 4)
    Yb = forward(qc, big, V[0])
    for x, y in zip(big, Yb, strict=True):
        np.testing.assert_allclose(y, statevector_output(qc, x, V[0]), atol=TOL)
    y0 = forward(qc, big[0], V[0])
    assert y0.shape == (4,)
    np.testing.assert_allclose(y0, statevector_output(qc, big[0], V[0]), atol=TOL)


def test_inputs_are_not_modified():
    qc = pyramid(4)
    rng = np.random.default_rng(2)
    X, v, W = unit_rows(rng, 6, 4), rng.normal(size=6), rng.normal(size=(6, 4))
    copies = X.copy(), v.copy(), W.copy()
    forward(qc, X, v)
    forward(qc, X[:2], v)
    vjp(qc, X, v, W)
    for original, copy in zip((X, v, W), copies, strict=True):
        np.testing.assert_array_equal(original, copy)


def test_fixed_circuit_needs_no_values():
    qc = QuantumCircuit(3)
    qc.append(RBSGate(0.4), [0, 2])
    x = np.array([0.6, 0.0, 0.8])
    np.testing.assert_allclose(forward(qc, x), statevector_output(qc, x, []), atol=TOL)
    assert orthogonal_matrix(qc).shape == (3, 3)


# ----------------------------------------------------------------------------- gradients
def _loss_weights(rng, shape):
    return rng.normal(size=shape)


@settings(max_examples=10, deadline=None)
@given(
    family=st.sampled_from(FAMILIES + ["shared"]),
    n=st.integers(2, 7),
    seed=st.integers(0, 2**32 - 1),
)
def test_vjp_matches_central_differences(family, n, seed):
    rng = np.random.default_rng(seed)
    if "butterfly" in family:
        n = 2 ** int(np.log2(n))
    qc = shared_circuit() if family == "shared" else build(family, n, rng)
    n = qc.num_qubits
    P = qc.num_parameters
    B = 3
    V = rng.uniform(-np.pi, np.pi, (B, P))
    X = unit_rows(rng, B, n)
    W = _loss_weights(rng, (B, n))
    gv, gx = vjp(qc, X, V, W)
    assert gv.shape == (B, P) and gx.shape == (B, n)
    h = 1e-6
    fd = np.zeros((B, P))
    for p in range(P):
        e = np.zeros(P)
        e[p] = h
        plus = np.sum(W * forward(qc, X, V + e), axis=1)
        minus = np.sum(W * forward(qc, X, V - e), axis=1)
        fd[:, p] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(gv, fd, atol=1e-6)
    # dL/dX = O^T W: the inverse circuit, by statevector, applied to W
    for b in range(B):
        bound = qc.assign_parameters(V[b])
        out = unary_statevector(W[b]).evolve(bound.inverse()).data[[2**j for j in range(n)]]
        np.testing.assert_allclose(gx[b], out.real, atol=TOL)
    # summed reduction equals the gradient of the summed loss under shared values
    gsum, _ = vjp(qc, X, V[0], W, reduce="sum")
    fd_sum = np.zeros(P)
    for p in range(P):
        e = np.zeros(P)
        e[p] = h
        fd_sum[p] = (
            np.sum(W * forward(qc, X, V[0] + e)) - np.sum(W * forward(qc, X, V[0] - e))
        ) / (2 * h)
    np.testing.assert_allclose(gsum, fd_sum, atol=1e-6)


def test_vjp_matches_statevector_finite_differences():
    qc = shared_circuit()
    rng = np.random.default_rng(5)
    v = rng.uniform(-2, 2, 3)
    x = unit_rows(rng, 1, 5)[0]
    w = rng.normal(size=5)
    gv, gx = vjp(qc, x, v, w)
    assert gv.shape == (3,) and gx.shape == (5,)
    h = 1e-5
    for p in range(3):
        e = np.zeros(3)
        e[p] = h
        fd = (w @ statevector_output(qc, x, v + e) - w @ statevector_output(qc, x, v - e)) / (2 * h)
        assert gv[p] == pytest.approx(fd, abs=1e-8)


def test_jacobian_matches_statevector_finite_differences():
    qc = round_robin(5)
    rng = np.random.default_rng(8)
    v = rng.uniform(-np.pi, np.pi, qc.num_parameters)
    x = unit_rows(rng, 1, 5)[0]
    J = jacobian(qc, x, v)
    assert J.shape == (5, qc.num_parameters)
    h = 1e-5
    for p in range(qc.num_parameters):
        e = np.zeros(qc.num_parameters)
        e[p] = h
        fd = (statevector_output(qc, x, v + e) - statevector_output(qc, x, v - e)) / (2 * h)
        np.testing.assert_allclose(J[:, p], fd, atol=1e-8)


# ----------------------------------------------------------------------------- bad input
def test_unsupported_gate_is_named():
    qc = pyramid(3)
    qc.h(1)
    with pytest.raises(ValueError, match="'h'"):
        compile_unary(qc)
    qc = QuantumCircuit(2, 2)
    qc.append(RBSGate(0.1), [0, 1])
    qc.measure([0, 1], [0, 1])
    with pytest.raises(ValueError, match="'measure'"):
        forward(qc, [1.0, 0.0])


def test_global_phase_refused():
    qc = pyramid(2)
    qc.global_phase = 0.5
    with pytest.raises(ValueError, match="global phase"):
        compile_unary(qc)


def test_bad_shapes():
    qc = pyramid(3)
    with pytest.raises(ValueError, match="values"):
        orthogonal_matrix(qc, [0.1, 0.2])
    with pytest.raises(ValueError, match="values"):
        orthogonal_matrix(qc, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="values is required"):
        forward(qc, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="X must have shape"):
        forward(qc, np.ones((2, 4)), np.zeros(3))
    with pytest.raises(ValueError, match="rows"):
        forward(qc, np.ones((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        forward(qc, [np.nan, 0, 0], np.zeros(3))
    with pytest.raises(TypeError, match="real"):
        forward(qc, [1j, 0, 0], np.zeros(3))
    with pytest.raises(ValueError, match="grad_Y"):
        vjp(qc, np.ones((2, 3)), np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match="reduce"):
        vjp(qc, np.ones(3), np.zeros(3), np.ones(3), reduce="mean")
    with pytest.raises(ValueError, match="x must be a 1-dimensional"):
        jacobian(qc, np.ones((2, 3)), np.zeros(3))
    with pytest.raises(TypeError, match="circuit"):
        compile_unary("pyramid")


# ----------------------------------------------------------------------------- gate lists
def test_gate_list_matches_statevector_and_shared_parameters_in_one_layer():
    """from_gates (no QuantumCircuit) against the statevector of the equivalent circuit; two
    disjoint gates sharing a parameter and a fixed gate fall in one layer (add.at path)."""
    rng = np.random.default_rng(7)
    pairs = [(0, 1), (2, 3), (1, 2), (0, 3), (1, 2)]
    pidx = [0, 0, 1, -1, 2]
    coef, off = [0.7, -1.3, 2.0, 0.0, 1.0], [0.1, 0.0, -0.2, 0.4, 0.0]
    uc = UnaryCircuit.from_gates(4, pairs, pidx, coef, off)
    assert (uc.num_gates, uc.num_parameters) == (5, 3)
    p = [Parameter(f"p{k}") for k in range(3)]
    qc = QuantumCircuit(4)
    for (i, j), k, a, b in zip(pairs, pidx, coef, off, strict=True):
        qc.append(RBSGate(b if k < 0 else a * p[k] + b), [i, j])
    values = rng.normal(size=3)
    bind = dict(zip(p, values, strict=True))
    x = unit_rows(rng, 1, 4)[0]
    expected = statevector_output(qc.assign_parameters(bind), x, [])
    np.testing.assert_allclose(forward(uc, x, values), expected, atol=TOL)
    # gradient of w . y against central differences of the statevector oracle
    w = rng.normal(size=4)
    gv, _ = vjp(uc, x, values, w)
    eps = 1e-6
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        up = statevector_output(qc.assign_parameters(dict(zip(p, values + d, strict=True))), x, [])
        dn = statevector_output(qc.assign_parameters(dict(zip(p, values - d, strict=True))), x, [])
        assert abs(gv[k] - w @ (up - dn) / (2 * eps)) < 1e-7


def test_summed_gradient_matches_finite_differences_of_summed_loss():
    """reduce='sum' (no per-example array) against central differences of the batch loss."""
    rng = np.random.default_rng(3)
    qc = round_robin(6)
    uc = compile_unary(qc)
    X = unit_rows(rng, 9, 6)
    W = rng.normal(size=(9, 6))
    values = rng.normal(size=uc.num_parameters)
    gsum, _ = vjp(uc, X, values, W, reduce="sum")
    eps = 1e-6
    for k in range(uc.num_parameters):
        d = np.zeros(uc.num_parameters)
        d[k] = eps
        up = np.sum(W * np.array([statevector_output(qc, x, values + d) for x in X]))
        dn = np.sum(W * np.array([statevector_output(qc, x, values - d) for x in X]))
        assert abs(gsum[k] - (up - dn) / (2 * eps)) < 1e-6


def test_gate_list_bad_input():
    with pytest.raises(ValueError, match="pairs"):
        UnaryCircuit.from_gates(3, [(0, 3)])
    with pytest.raises(ValueError, match="pairs"):
        UnaryCircuit.from_gates(3, [(1, 1)])
    with pytest.raises(ValueError, match="parameter_index"):
        UnaryCircuit.from_gates(3, [(0, 1)], parameter_index=[0, 1])


@pytest.mark.parametrize(("B", "shared"), [(12, True), (3, True), (3, False), (1, False)])
def test_vjp_from_given_outputs_matches_statevector_finite_differences(B, shared):
    """``vjp(..., outputs=Y)`` starts the reverse pass at the forward's outputs: gradients
    against central differences of statevector outputs (an independent path), the caller's
    ``outputs`` left untouched, and a wrong shape refused."""
    qc = round_robin(5)
    rng = np.random.default_rng(B)
    P = qc.num_parameters
    V = rng.uniform(-np.pi, np.pi, P if shared else (B, P))
    X = unit_rows(rng, B, 5)
    W = _loss_weights(rng, (B, 5))
    Y = forward(qc, X, V)
    kept = Y.copy()
    gv, gx = vjp(qc, X, V, W, reduce="sum", outputs=Y)
    np.testing.assert_array_equal(Y, kept)
    h = 1e-5
    fd = np.zeros(P)
    for p in range(P):
        e = np.zeros(P)
        e[p] = h
        for b in range(B):
            vb = V if shared else V[b]
            fd[p] += W[b] @ (statevector_output(qc, X[b], vb + e)
                             - statevector_output(qc, X[b], vb - e)) / (2 * h)
    np.testing.assert_allclose(gv, fd, atol=1e-7)
    for b in range(B):  # dL/dX = O^T W, by the inverse circuit on a statevector
        bound = qc.assign_parameters(V if shared else V[b])
        out = unary_statevector(W[b]).evolve(bound.inverse()).data[[2**j for j in range(5)]]
        np.testing.assert_allclose(gx[b], out.real, atol=TOL)
    with pytest.raises(ValueError, match="outputs must have the output's shape"):
        vjp(qc, X, V, W, outputs=Y[:, :4])
