"""Unary, matrix and distribution loaders against exact statevectors (docs/design.md, "Oracles")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import transpile
from qiskit.quantum_info import Operator, Statevector
from qiskit_aer import AerSimulator

from qdensity.analysis import depth_of_gates, is_hamming_weight_preserving
from qdensity.circuits.loaders import (
    LAYOUTS,
    distribution_loader,
    loader_angles,
    loader_start_qubit,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)

ATOL = 1e-10
CZ_BASIS = ["cz", "rz", "sx", "x"]
CX_BASIS = ["cx", "rz", "sx", "x"]


# ---------------------------------------------------------------------------- oracles


def unary_state(x) -> np.ndarray:
    """``x / ||x||`` written into statevector entries ``2**j`` (independent of the loaders)."""
    x = np.asarray(x, dtype=float)
    out = np.zeros(2 ** x.size, dtype=complex)
    for j, v in enumerate(x):
        out[2**j] = v
    return out / math.hypot(*x.tolist())  # hypot scales: no under/overflow


def matrix_state(X) -> np.ndarray:
    """``sum_ij X_ij |e_i>|e_j> / ||X||_F`` at entries ``2**i + 2**(n + j)``."""
    X = np.asarray(X, dtype=float)
    n, d = X.shape
    out = np.zeros(2 ** (n + d), dtype=complex)
    for i in range(n):
        for j in range(d):
            out[2**i + 2 ** (n + j)] = X[i, j]
    return out / math.hypot(*X.ravel().tolist())


def expected_rbs_depth(d: int, layout: str) -> int:
    return {
        "parallel": math.ceil(math.log2(d)),
        "diagonal": d - 1,
        "semi_diagonal": math.ceil(d / 2),
    }[layout]


def assert_state(circuit, expected, atol=ATOL):
    sv = Statevector(circuit).data
    np.testing.assert_allclose(sv, expected, atol=atol, rtol=0)


# ---------------------------------------------------------------------------- strategies


@st.composite
def vectors(draw, d: int) -> np.ndarray:
    """Length-d vectors with negatives, exact zeros (random masks, zero halves), one-hots."""
    kind = draw(st.sampled_from(["dense", "masked", "one_hot", "zero_half"]))
    if kind == "one_hot":
        x = np.zeros(d)
        x[draw(st.integers(0, d - 1))] = draw(st.sampled_from([1.0, -1.0, 2.5, -0.3]))
        return x
    entries = st.floats(-10, 10, allow_nan=False, allow_infinity=False, allow_subnormal=False)
    values = draw(st.lists(entries, min_size=d, max_size=d))
    x = np.array(values)
    if kind == "masked":
        mask = np.array(draw(st.lists(st.booleans(), min_size=d, max_size=d)))
        x[mask] = 0.0
    elif kind == "zero_half":
        cut = draw(st.integers(1, d - 1))
        if draw(st.booleans()):
            x[:cut] = 0.0
        else:
            x[cut:] = 0.0
    if not np.any(x):
        x[draw(st.integers(0, d - 1))] = -1.0
    return x


# ---------------------------------------------------------------------------- unary loader


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("d", range(2, 13))
@settings(max_examples=8, deadline=None)
@given(data=st.data())
def test_unary_loader_statevector(d, layout, data):
    x = data.draw(vectors(d))
    qc = unary_loader(x, layout)
    assert qc.num_qubits == d
    assert_state(qc, unary_state(x))


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("d", range(2, 13))
def test_unary_loader_one_hot_and_zero_subtrees(d, layout):
    for k in range(d):
        for value in (1.0, -2.0):
            x = np.zeros(d)
            x[k] = value
            assert_state(unary_loader(x, layout), unary_state(x))
    # Zeros everywhere except both ends, and except the middle pair.
    x = np.zeros(d)
    x[0], x[-1] = -1.5, 0.5
    assert_state(unary_loader(x, layout), unary_state(x))
    x = np.zeros(d)
    x[d // 2 - 1 : d // 2 + 1] = [0.3, -0.4]
    assert_state(unary_loader(x, layout), unary_state(x))


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("scale", [1e-200, 1e-30, 1e30, 1e200])
def test_unary_loader_extreme_scales(layout, scale):
    x = np.array([0.5, -1.0, 0.0, 2.0, 0.25, -0.75])
    assert_state(unary_loader(scale * x, layout), unary_state(x))


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("d", range(2, 17))
def test_unary_loader_gate_counts_and_depth(d, layout):
    x = np.random.default_rng(d).normal(size=d)
    for qc in (unary_loader(x, layout), unary_loader_template(d, layout)):
        ops = qc.count_ops()
        assert dict(ops) == {"x": 1, "rbs": d - 1}
        assert qc.data[0].operation.name == "x"
        assert qc.find_bit(qc.data[0].qubits[0]).index == loader_start_qubit(d, layout)
        assert depth_of_gates(qc, ["rbs"]) == expected_rbs_depth(d, layout)
        rest = qc.copy_empty_like()
        for inst in qc.data[1:]:
            rest.append(inst)
        assert is_hamming_weight_preserving(rest)


@pytest.mark.parametrize("d", range(2, 13))
def test_diagonal_and_semi_diagonal_are_nearest_neighbour(d):
    for layout in ("diagonal", "semi_diagonal"):
        qc = unary_loader(np.ones(d), layout)
        for inst in qc.data[1:]:
            i, j = (qc.find_bit(q).index for q in inst.qubits)
            assert abs(i - j) == 1


def test_parallel_heads_shorten_the_tree():
    # d = 8: a first-index-head tree has total qubit distance 4 + 2*2 + 4*1 = 12; the least
    # possible is 9 (the root and the two level-2 gates cannot all be adjacent).
    qc = unary_loader(np.ones(8), "parallel")
    dist = [abs(qc.find_bit(a).index - qc.find_bit(b).index) for a, b in
            (inst.qubits for inst in qc.data[1:])]
    assert sum(dist) == 9


# ---------------------------------------------------------------------------- templates


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("d", [2, 3, 5, 8, 11])
def test_template_and_batch_angles(d, layout):
    rng = np.random.default_rng(100 + d)
    X = rng.normal(size=(6, d))
    X[1, : d // 2] = 0.0
    X[2] = 0.0
    X[2, -1] = -3.0
    tpl = unary_loader_template(d, layout)
    assert tpl.num_parameters == d - 1
    assert [p.name for p in tpl.parameters] == [f"x[{k}]" for k in range(d - 1)]
    angles = loader_angles(X, layout)
    assert angles.shape == (6, d - 1)
    for b in range(X.shape[0]):
        bound = tpl.assign_parameters(angles[b])
        assert_state(bound, unary_state(X[b]))
        assert unary_loader(X[b], layout) == tpl.assign_parameters(loader_angles(X[b], layout))
        np.testing.assert_allclose(loader_angles(X[b], layout), angles[b], atol=1e-15)
    assert loader_angles(X[0], layout).shape == (d - 1,)


def test_template_parameter_prefix():
    tpl = unary_loader_template(4, "diagonal", parameter_prefix="phi")
    assert [p.name for p in tpl.parameters] == ["phi[0]", "phi[1]", "phi[2]"]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_transpiled_template_serves_a_dataset(layout):
    d = 6
    tpl = unary_loader_template(d, layout)
    tqc = transpile(tpl, basis_gates=CZ_BASIS, optimization_level=2, seed_transpiler=3)
    assert set(tqc.count_ops()) <= set(CZ_BASIS)
    X = np.random.default_rng(7).normal(size=(4, d))
    X[0, 1:4] = 0.0
    angles = loader_angles(X, layout)
    for b in range(X.shape[0]):
        bound = tqc.assign_parameters(dict(zip(tpl.parameters, angles[b], strict=True)))
        assert_state(bound, unary_state(X[b]), atol=1e-9)


# ---------------------------------------------------------------------------- matrix loader


@pytest.mark.parametrize("layout", LAYOUTS)
@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_matrix_loader_statevector(layout, data):
    n = data.draw(st.integers(1, 4))
    d = data.draw(st.integers(2, 5))
    seed = data.draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d))
    X[rng.random((n, d)) < data.draw(st.sampled_from([0.0, 0.3, 0.6]))] = 0.0
    if n > 1 and data.draw(st.booleans()):
        X[data.draw(st.integers(0, n - 1))] = 0.0  # a whole zero row
    if not np.any(X):
        X[0, 0] = 1.0
    qc = matrix_loader(X, layout)
    assert [r.name for r in qc.qregs] == ["row", "col"]
    assert [r.size for r in qc.qregs] == [n, d]
    assert_state(qc, matrix_state(X))
    m = int(np.count_nonzero(np.any(X != 0, axis=1)))
    ops = qc.count_ops()
    assert ops.get("rbs", 0) == (n - 1) + (2 * m - 1) * (d - 1)
    assert ops["cx"] == m
    assert ops["x"] == 1


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_matrix_loader_extreme_scales(scale):
    X = np.array([[1.0, -2.0, 0.0], [0.0, 0.0, 0.0], [0.5, 3.0, -1.0]])
    assert_state(matrix_loader(scale * X), matrix_state(X))


def test_matrix_loader_single_column_and_row():
    assert_state(matrix_loader([[2.0], [0.0], [-1.0]]), matrix_state([[2.0], [0.0], [-1.0]]))
    assert_state(matrix_loader([[0.0, -1.0, 3.0]]), matrix_state([[0.0, -1.0, 3.0]]))


# ---------------------------------------------------------------------------- distribution


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("K", range(1, 9))
def test_distribution_loader(K, layout):
    rng = np.random.default_rng(K)
    alpha = rng.random(K)
    if K > 2:
        alpha[rng.integers(K)] = 0.0
    alpha = alpha / alpha.sum()
    qc = distribution_loader(alpha, layout)
    assert qc.name == "load_sqrt_alpha"
    assert qc.num_qubits == K
    expected = np.zeros(2**K)
    for k in range(K):
        expected[2**k] = math.sqrt(alpha[k])
    assert_state(qc, expected)
    assert dict(qc.count_ops()) == ({"x": 1, "rbs": K - 1} if K > 1 else {"x": 1})


def test_distribution_loader_parallel_depth():
    alpha = np.full(8, 1 / 8)
    assert depth_of_gates(distribution_loader(alpha), ["rbs"]) == 3


# ---------------------------------------------------------------------------- transpiling


def _circuits():
    x = np.array([0.7, 0.0, -1.2, 0.4, 0.0])
    X = np.array([[1.0, -2.0, 0.0, 0.5], [0.0, 0.0, 0.0, 0.0], [0.3, 0.0, 1.0, -1.0]])
    alpha = np.array([0.1, 0.0, 0.4, 0.5])
    for layout in LAYOUTS:
        yield f"unary-{layout}", unary_loader(x, layout), unary_state(x)
    yield "matrix-parallel", matrix_loader(X, "parallel"), matrix_state(X)
    yield "matrix-semi", matrix_loader(X, "semi_diagonal"), matrix_state(X)
    yield "distribution", distribution_loader(alpha), unary_state(np.sqrt(alpha))


CIRCUITS = list(_circuits())


@pytest.mark.parametrize("level", [0, 1, 2, 3])
@pytest.mark.parametrize(("label", "qc", "expected"), CIRCUITS, ids=[c[0] for c in CIRCUITS])
def test_transpiles_to_cz_basis(label, qc, expected, level):
    tqc = transpile(qc, basis_gates=CZ_BASIS, optimization_level=level, seed_transpiler=11)
    assert set(tqc.count_ops()) <= set(CZ_BASIS)
    assert_state(tqc, expected, atol=1e-9)
    assert Operator.from_circuit(tqc).equiv(Operator(qc), atol=1e-8)


@pytest.mark.parametrize(("label", "qc", "expected"), CIRCUITS, ids=[c[0] for c in CIRCUITS])
def test_runs_on_aer_in_cx_basis(label, qc, expected):
    tqc = transpile(qc, basis_gates=CX_BASIS, optimization_level=3, seed_transpiler=5)
    assert set(tqc.count_ops()) <= set(CX_BASIS)
    tqc.save_statevector()
    sim = AerSimulator(method="statevector", seed_simulator=1)
    sv = np.asarray(sim.run(tqc).result().get_statevector())
    np.testing.assert_allclose(sv, expected, atol=1e-9, rtol=0)


def test_rbs_costs_two_cz_each():
    qc = unary_loader(np.arange(1.0, 9.0), "parallel")
    tqc = transpile(qc, basis_gates=CZ_BASIS, optimization_level=3, seed_transpiler=1)
    assert tqc.count_ops()["cz"] == 2 * 7


# ---------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("x", "match"),
    [
        ([0.0, 0.0, 0.0], "zero vector"),
        ([1.0, np.nan], "finite"),
        ([1.0, np.inf, 0.0], "finite"),
        ([1.0], "length >= 2"),
        ([[1.0, 2.0], [3.0, 4.0]], "1-dimensional"),
    ],
)
def test_unary_loader_refuses_bad_vectors(x, match):
    with pytest.raises(ValueError, match=match):
        unary_loader(x)


@pytest.mark.parametrize(
    "call",
    [
        lambda: unary_loader([1.0, 2.0], "tree"),
        lambda: unary_loader_template(4, "Parallel"),
        lambda: loader_angles([1.0, 2.0], "chain"),
        lambda: matrix_loader([[1.0, 2.0]], "butterfly"),
    ],
)
def test_unknown_layout(call):
    with pytest.raises(ValueError, match="layout must be one of 'parallel', 'diagonal'"):
        call()


def test_layout_of_the_wrong_type():
    with pytest.raises(TypeError, match="layout must be one of 'parallel', 'diagonal'"):
        distribution_loader([1.0], None)


def test_loader_angles_refuses_bad_input():
    with pytest.raises(ValueError, match=r"zero rows: \[1\]"):
        loader_angles([[1.0, 2.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match="shape"):
        loader_angles(np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match="d >= 2"):
        loader_angles([[1.0], [2.0]])
    with pytest.raises(ValueError, match="finite"):
        loader_angles([[1.0, np.nan]])


def test_template_refuses_bad_input():
    with pytest.raises(ValueError, match="d must be an int >= 2"):
        unary_loader_template(1)
    with pytest.raises(TypeError, match="d must be an int"):
        unary_loader_template(3.0)
    with pytest.raises(ValueError, match="parameter_prefix"):
        unary_loader_template(3, parameter_prefix="")


def test_matrix_loader_refuses_bad_input():
    with pytest.raises(ValueError, match="zero matrix"):
        matrix_loader(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="2-dimensional"):
        matrix_loader([1.0, 2.0])
    with pytest.raises(ValueError, match="finite"):
        matrix_loader([[1.0, np.inf]])


def test_distribution_loader_refuses_bad_input():
    with pytest.raises(ValueError, match="sum to 1"):
        distribution_loader([0.5, 0.4])
    with pytest.raises(ValueError, match="non-negative"):
        distribution_loader([1.5, -0.5])
    with pytest.raises(ValueError, match="finite"):
        distribution_loader([np.nan, 1.0])
