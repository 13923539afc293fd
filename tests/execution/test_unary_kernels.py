"""The unary engine's sparse-matrix kernels (shared angles) against dense Givens products.

The compiled gate loop (:mod:`qdensity.execution.unary._kernels`) and every path of
``qdensity.execution.unary._plan`` (full layers fused in pairs or left single,
in-place sparse layers, odd ``n`` padding, the reverse pass's dot chunks, the plain scipy
fallback) is checked against the oracle ``O = R_G ... R_1`` built from explicit ``n x n``
rotation matrices, and its derivative ``O_after R'_g O_before`` per gate.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.execution import _numba
from qdensity.execution import _threads as _unary_threads
from qdensity.execution.unary import UnaryCircuit, forward, orthogonal_matrix, vjp
from qdensity.execution.unary import _plan as _unary_plan

TOL = 1e-11


@pytest.fixture(autouse=True, params=["numba", "numpy"])
def backend(request, monkeypatch):
    """Every oracle test runs on the compiled gate loop (numba, core) and on the numpy /
    scipy layer kernels (the path without numba, as ``QDENSITY_NUMBA=0`` gives it)."""
    if request.param == "numba" and not _numba.available():
        assert os.environ.get("QDENSITY_NUMBA", "1") == "0", "numba is a core dependency"
        pytest.skip("QDENSITY_NUMBA=0 switches the compiled kernels off")
    if request.param == "numpy":
        monkeypatch.setattr(_numba, "numba", None)
    return request.param


def rotation(n, i, j, a, derivative=False):
    c, s = (-np.sin(a), np.cos(a)) if derivative else (np.cos(a), np.sin(a))
    R = np.zeros((n, n)) if derivative else np.eye(n)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def oracle(n, pairs, angles):
    """``O`` and ``dO/dangle_g`` for every gate (dense products)."""
    mats = [rotation(n, i, j, a) for (i, j), a in zip(pairs, angles, strict=True)]
    O = np.eye(n)
    for R in mats:
        O = R @ O
    grads = []
    for g, ((i, j), a) in enumerate(zip(pairs, angles, strict=True)):
        before, after = np.eye(n), np.eye(n)
        for R in mats[:g]:
            before = R @ before
        for R in mats[g + 1:]:
            after = R @ after
        grads.append(after @ rotation(n, i, j, a, derivative=True) @ before)
    return O, grads


def check(n, pairs, pidx=None, coef=None, off=None, batch=5, seed=0):
    rng = np.random.default_rng(seed)
    uc = UnaryCircuit.from_gates(n, pairs, parameter_index=pidx, coefficient=coef, offset=off)
    values = rng.normal(size=uc.num_parameters)
    angles = uc.angles(values)
    O, dO = oracle(n, [tuple(p) for p in np.asarray(pairs).reshape(-1, 2)], angles)
    X, GY = rng.normal(size=(batch, n)), rng.normal(size=(batch, n))
    np.testing.assert_allclose(forward(uc, X, values), X @ O.T, atol=TOL)
    np.testing.assert_allclose(orthogonal_matrix(uc, values), O, atol=TOL)
    per_gate = np.array([np.einsum("bk,kj,bj->b", GY, D, X) for D in dO]).reshape(-1, batch)
    expected = np.zeros((uc.num_parameters, batch))
    for g, p in enumerate(uc.parameter_index):
        if p >= 0:
            expected[p] += uc.coefficient[g] * per_gate[g]
    g_sum, gx = vjp(uc, X, values, GY, reduce="sum")
    np.testing.assert_allclose(g_sum, expected.sum(axis=1), atol=TOL)
    np.testing.assert_allclose(gx, GY @ O, atol=TOL)
    g_each, gx = vjp(uc, X, values, GY)
    np.testing.assert_allclose(g_each, expected.T, atol=TOL)
    np.testing.assert_allclose(gx, GY @ O, atol=TOL)
    return uc


def rr(n, repeat=1):
    return [p for _ in range(repeat) for rnd in round_robin_pairs(n) for p in rnd]


@pytest.mark.parametrize("n", [2, 3, 4, 5, 8, 9])
def test_round_robin_full_layers(n):
    uc = check(n, rr(n))
    assert all(st.dense for st in uc._plan.steps)


@pytest.mark.parametrize("n", [7, 10])
def test_ladder_layers_rotate_in_place(n):
    """One gate per layer: the in-place path (and dense layers between them)."""
    uc = check(n, [(k, k + 1) for k in range(n - 1)] + rr(n) + [(n - 1, 0)])
    kinds = {st.dense for st in uc._plan.steps}
    assert kinds == {True, False}


def test_fixed_angles_shared_and_repeated_parameters():
    rng = np.random.default_rng(3)
    n = 7
    pairs = [tuple(int(q) for q in rng.choice(n, 2, replace=False)) for _ in range(40)]
    pidx = rng.integers(-1, 4, size=len(pairs))  # fixed gates, shared and repeated params
    check(n, pairs, pidx=pidx, coef=rng.normal(size=len(pairs)),
          off=rng.normal(size=len(pairs)), batch=4)


def test_shared_parameter_within_one_layer():
    check(6, [(0, 1), (2, 3), (4, 5), (1, 2), (3, 4)], pidx=[0, 0, 1, 1, 0],
          coef=[1.0, -2.0, 0.5, 1.0, 3.0], off=[0.1, 0.0, 0.2, 0.0, -0.3])


@pytest.mark.parametrize("pairs", [[(0, 1)], [(1, 0)], [(0, 1), (2, 3), (4, 5)], [(2, 0)]])
def test_single_layer(pairs):
    check(max(max(p) for p in pairs) + 1, pairs)


@pytest.mark.parametrize("batch", [1, 2, 12])
def test_batch_sizes(batch):
    """Batch 1, and a batch larger than n (``O`` built first, then one product)."""
    check(5, rr(5, 2), batch=batch)


def test_single_input_and_values_shapes():
    uc = UnaryCircuit.from_gates(4, rr(4))
    rng = np.random.default_rng(1)
    x, v, g = rng.normal(size=4), rng.normal(size=uc.num_parameters), rng.normal(size=4)
    O, dO = oracle(4, rr(4), uc.angles(v))
    np.testing.assert_allclose(forward(uc, x, v), O @ x, atol=TOL)
    gv, gx = vjp(uc, x, v, g)
    np.testing.assert_allclose(gv, [g @ D @ x for D in dO], atol=TOL)
    np.testing.assert_allclose(gx, g @ O, atol=TOL)


def test_reverse_pass_chunks(monkeypatch):
    """Dots batched over chunks of one or two layer outputs (wrap-around of the buffer)."""
    monkeypatch.setattr(_unary_plan, "_CHUNK_BYTES", 1)
    check(6, rr(6, 2) + [(0, 5), (1, 4)] + rr(6))
    check(5, [(0, 1), (1, 2), (2, 3), (3, 4)] + rr(5))


def test_plain_scipy_fallback(monkeypatch):
    """Without the compiled entry point the kernels use ``csr_matrix @ X``: same results."""
    monkeypatch.setattr(_unary_plan, "_csr_matvecs", None)
    check(5, rr(5, 2) + [(0, 1), (2, 4)])
    check(8, [(k, k + 1) for k in range(7)] + rr(8))


def test_no_gates():
    uc = UnaryCircuit.from_gates(3, np.zeros((0, 2), dtype=int))
    x = np.arange(6.0).reshape(2, 3)
    np.testing.assert_array_equal(forward(uc, x, []), x)
    gv, gx = vjp(uc, x, [], x)
    assert gv.shape == (2, 0)
    np.testing.assert_array_equal(gx, x)


def test_inputs_untouched_and_outputs_fresh():
    uc = UnaryCircuit.from_gates(4, rr(4))
    rng = np.random.default_rng(2)
    X, v, G = rng.normal(size=(3, 4)), rng.normal(size=6), rng.normal(size=(3, 4))
    keep = X.copy(), v.copy(), G.copy()
    Y1 = forward(uc, X, v)
    Y1[:] = 0.0
    Y2 = forward(uc, X, v)
    vjp(uc, X, v, G, reduce="sum")
    for a, b in zip((X, v, G), keep, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.abs(Y2).max() > 0


@pytest.fixture
def threads(monkeypatch):
    """Force column blocks in threads at any width (the numpy path's threads: the compiled
    path has none); returns a setter of the thread count and the list of block counts the
    forward passes used."""
    monkeypatch.setattr(_numba, "numba", None)
    monkeypatch.setattr(_unary_threads, "MIN_WORK", 0)
    monkeypatch.setattr(_unary_threads, "MIN_COLUMNS", 1)
    used = []
    run_blocks = _unary_plan.run_blocks

    def spy(fn, ranges):
        used.append(len(ranges))
        run_blocks(fn, ranges)

    monkeypatch.setattr(_unary_plan, "run_blocks", spy)

    def set_threads(k):
        monkeypatch.setenv(_unary_threads.ENV, str(k))

    return set_threads, used


@pytest.mark.parametrize("n, pairs", [(8, rr(8, 2)), (9, rr(9) + [(0, 8), (2, 3)]),
                                      (6, [(0, 1), (1, 2), (2, 3)] + rr(6))])
@pytest.mark.parametrize("k", [2, 3, 5])
def test_threaded_forward_bit_for_bit(threads, n, pairs, k):
    """Column blocks in threads give exactly the single-thread bits, forward and gradient."""
    set_threads, used = threads
    uc = UnaryCircuit.from_gates(n, pairs)
    rng = np.random.default_rng(k)
    values = rng.normal(size=uc.num_parameters)
    for batch in (37, 5):  # B > n: the columns of the identity in blocks; B < n: X's
        X, GY = rng.normal(size=(batch, n)), rng.normal(size=(batch, n))
        set_threads(1)
        one = forward(uc, X, values), vjp(uc, X, values, GY), vjp(uc, X, values, GY, reduce="sum")
        assert used == []
        set_threads(k)
        many = forward(uc, X, values), vjp(uc, X, values, GY), vjp(uc, X, values, GY, reduce="sum")
        assert used and min(used) > 1
        used.clear()
        np.testing.assert_array_equal(many[0], one[0])
        for a, b in zip(many[1:], one[1:], strict=True):
            np.testing.assert_array_equal(a[0], b[0])
            np.testing.assert_array_equal(a[1], b[1])


def test_threaded_forward_against_oracle(threads):
    """Threaded paths (odd n padding, sparse in-place layers) against dense Givens products."""
    set_threads, used = threads
    set_threads(3)
    check(5, rr(5, 2) + [(0, 1), (2, 4)], batch=13)
    check(8, [(k, k + 1) for k in range(7)] + rr(8), batch=12)
    check(12, rr(12) + [(0, 11), (3, 4)], batch=7)  # B < n: blocks of X's own columns
    assert used and min(used) == 3


def test_thread_count_from_environment(monkeypatch):
    monkeypatch.delenv(_unary_threads.ENV, raising=False)
    default = min(_unary_threads.usable_cores(), _unary_threads.MAX_THREADS)
    assert _unary_threads.num_threads() == default
    for raw, k in (("", default), (" 3 ", 3), ("1", 1), ("12", 12)):
        monkeypatch.setenv(_unary_threads.ENV, raw)
        assert _unary_threads.num_threads() == k
    monkeypatch.setattr(_unary_threads, "MIN_WORK", 1000)
    monkeypatch.setenv(_unary_threads.ENV, "8")
    assert _unary_threads.blocks(10, 10**6) == [(0, 5), (5, 10)]  # at least 4 columns each
    assert _unary_threads.blocks(64, 10) == [(0, 64)]  # too little work per thread
    monkeypatch.setenv(_unary_threads.ENV, "1")
    assert _unary_threads.blocks(64, 10**6) == [(0, 64)]


@pytest.mark.parametrize("raw", ["abc", "2.5", "0", "-1", "two"])
def test_thread_count_refuses_bad_environment(monkeypatch, raw):
    monkeypatch.setenv(_unary_threads.ENV, raw)
    uc = UnaryCircuit.from_gates(4, rr(4))
    with pytest.raises(ValueError, match="QDENSITY_NUM_THREADS must be an integer >= 1"):
        forward(uc, np.eye(4), np.zeros(6))
