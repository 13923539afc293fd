"""The unary engine's whole-circuit compiled calls (numba) against independent oracles.

Every path of :mod:`qdensity.execution.unary._compiled` -- the small-circuit call that computes
the angles itself, the call given the angles' cosines and sines, row blocks in threads, ``O``
composed first (then BLAS), per-row values, per-example and summed gradients, the reverse pass
started from given outputs -- is checked against the dense product of ``n x n`` Givens rotation
matrices and, for the gradient, central finite differences of that product.
"""

from __future__ import annotations

import numpy as np
import pytest
from _givens import dense

from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.execution import _numba
from qdensity.execution import _threads as _unary_threads
from qdensity.execution.unary import UnaryCircuit, _compiled, forward, vjp

pytestmark = pytest.mark.skipif(not _numba.available(), reason="numba switched off")

TOL = 1e-11



def circuit(n, seed):
    """Round-robin rounds, a ladder, fixed gates, shared and affine parameters."""
    rng = np.random.default_rng(seed)
    pairs = [p for rnd in round_robin_pairs(n) for p in rnd] + [(k, k + 1) for k in range(n - 1)]
    G = len(pairs)
    P = G // 2
    pidx = rng.integers(-1, P, size=G)
    return UnaryCircuit.from_gates(n, pairs, parameter_index=pidx, coefficient=rng.normal(size=G),
                                   offset=rng.normal(size=G), num_parameters=P), pairs


def oracle(uc, pairs, X, V, GY):
    """Outputs, per-example parameter gradients (B, P) by central differences, dL/dX."""
    B, n = X.shape
    rows = np.broadcast_to(V, (B, uc.num_parameters)) if V.ndim == 1 else V
    Y = np.stack([dense(n, pairs, uc.angles(v)) @ x for x, v in zip(X, rows, strict=True)])
    gx = np.stack([g @ dense(n, pairs, uc.angles(v)) for g, v in zip(GY, rows, strict=True)])
    h = 1e-6
    gv = np.zeros((B, uc.num_parameters))
    for b in range(B):
        for p in range(uc.num_parameters):
            up, dn = rows[b].copy(), rows[b].copy()
            up[p] += h
            dn[p] -= h
            diff = dense(n, pairs, uc.angles(up)) - dense(n, pairs, uc.angles(dn))
            gv[b, p] = GY[b] @ diff @ X[b] / (2 * h)
    return Y, gv, gx


def check(uc, pairs, B, per_row, seed=0):
    rng = np.random.default_rng(seed)
    n, P = uc.num_qubits, uc.num_parameters
    X, GY = rng.normal(size=(B, n)), rng.normal(size=(B, n))
    V = rng.normal(size=(B, P) if per_row else P)
    Y, gv, gx = oracle(uc, pairs, X, V, GY)
    np.testing.assert_allclose(forward(uc, X, V), Y, atol=TOL)
    g_each, g_x = vjp(uc, X, V, GY)
    np.testing.assert_allclose(g_each, gv, atol=1e-7)  # central differences: O(h^2) + round-off
    np.testing.assert_allclose(g_x, gx, atol=TOL)
    g_sum, g_x = vjp(uc, X, V, GY, reduce="sum", outputs=Y)
    np.testing.assert_allclose(g_sum, gv.sum(axis=0), atol=1e-7)
    np.testing.assert_allclose(g_x, gx, atol=TOL)


@pytest.mark.parametrize("n", [2, 5, 8])
@pytest.mark.parametrize("per_row", [False, True])
@pytest.mark.parametrize("small", [True, False])
def test_compiled_paths_against_dense_oracle(monkeypatch, n, per_row, small):
    """Angles in the kernel call (small circuits) or computed before it (``_SMALL = 0``)."""
    if not small:
        monkeypatch.setattr(_compiled, "_SMALL", 0)
    uc, pairs = circuit(n, seed=n)
    for B in (1, 3, 11):
        check(uc, pairs, B, per_row, seed=B)


def test_composed_forward_against_dense_oracle(monkeypatch):
    """``O`` built first and multiplied with BLAS, forced at any size."""
    monkeypatch.setattr(_compiled, "COMPOSE_WEIGHT", 0.0)
    assert _compiled.composed_cheaper(4, 1, 1)
    for n in (3, 6):
        uc, pairs = circuit(n, seed=10 + n)
        check(uc, pairs, 7, per_row=False)


def test_compose_choice_by_cost():
    """Rotating the rows wins for batch 64 on a round-robin circuit; a deep circuit on a wide
    batch is composed."""
    for n in (16, 64, 256, 1024):
        assert not _compiled.composed_cheaper(n, n * (n - 1) // 2, 64)
    assert _compiled.composed_cheaper(16, 100 * 16 * 15 // 2, 4096)


@pytest.fixture
def blocks_in_threads(monkeypatch):
    """Row blocks in threads at any width; returns a setter of the thread count and the
    block counts used."""
    monkeypatch.setattr(_unary_threads, "MIN_WORK", 0)
    monkeypatch.setattr(_unary_threads, "MIN_COLUMNS", 1)
    used = []
    run_blocks = _compiled.run_blocks

    def spy(fn, ranges):
        used.append(len(ranges))
        run_blocks(fn, ranges)

    monkeypatch.setattr(_compiled, "run_blocks", spy)

    def set_threads(k):
        monkeypatch.setenv(_unary_threads.ENV, str(k))

    return set_threads, used


def test_blocks_run_by_one_thread_never_wait_for_a_missing_one(monkeypatch):
    """The shared angles' sines and cosines are computed in slices by the block threads; a
    thread waits only for slices another running thread has started. With every block run in
    turn by the calling thread (pool threads that never start), the calls finish, with the
    one-thread bits."""
    import threading

    uc, _ = circuit(9, seed=5)
    rng = np.random.default_rng(5)
    X, GY = rng.normal(size=(12, 9)), rng.normal(size=(12, 9))
    V = rng.normal(size=uc.num_parameters)
    monkeypatch.setenv(_unary_threads.ENV, "1")
    one = forward(uc, X, V), vjp(uc, X, V, GY, reduce="sum")
    monkeypatch.setattr(_unary_threads, "MIN_WORK", 0)
    monkeypatch.setattr(_unary_threads, "MIN_COLUMNS", 1)
    monkeypatch.setattr(_compiled, "run_blocks", lambda fn, ranges: [fn(*r) for r in ranges])
    monkeypatch.setenv(_unary_threads.ENV, "3")
    got = []
    worker = threading.Thread(target=lambda: got.append(
        (forward(uc, X, V), vjp(uc, X, V, GY, reduce="sum"))), daemon=True)
    worker.start()
    worker.join(timeout=120)
    assert got, "a block waited for sines and cosines that no thread was computing"
    np.testing.assert_array_equal(got[0][0], one[0])
    np.testing.assert_array_equal(got[0][1][1], one[1][1])
    np.testing.assert_allclose(got[0][1][0], one[1][0], rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize("per_row", [False, True])
def test_row_blocks_in_threads(blocks_in_threads, k, per_row):
    """Blocks in threads: against the oracle; outputs, per-example gradients and dL/dX are
    the one-block bits (a summed gradient adds the blocks' partial sums)."""
    set_threads, used = blocks_in_threads
    uc, pairs = circuit(7, seed=k)
    set_threads(k)
    check(uc, pairs, 10, per_row, seed=k)
    assert used and min(used) == k
    rng = np.random.default_rng(k)
    X, GY = rng.normal(size=(10, 7)), rng.normal(size=(10, 7))
    V = rng.normal(size=(10, uc.num_parameters) if per_row else uc.num_parameters)
    many = forward(uc, X, V), vjp(uc, X, V, GY), vjp(uc, X, V, GY, reduce="sum")
    set_threads(1)
    one = forward(uc, X, V), vjp(uc, X, V, GY), vjp(uc, X, V, GY, reduce="sum")
    np.testing.assert_array_equal(many[0], one[0])
    np.testing.assert_array_equal(many[1][0], one[1][0])
    np.testing.assert_array_equal(many[1][1], one[1][1])
    np.testing.assert_array_equal(many[2][1], one[2][1])
    np.testing.assert_allclose(many[2][0], one[2][0], rtol=1e-13, atol=1e-13)


def test_inputs_of_other_dtypes_and_layouts():
    """Integer, Fortran-ordered, strided and read-only inputs: same numbers."""
    uc, pairs = circuit(5, seed=1)
    rng = np.random.default_rng(1)
    V = rng.normal(size=uc.num_parameters)
    Xi = rng.integers(-3, 4, size=(6, 5))
    expected = Xi @ dense(5, pairs, uc.angles(V)).T
    frozen = Xi.astype(float)
    frozen.setflags(write=False)
    for X in (Xi, np.asfortranarray(Xi, dtype=float), np.repeat(Xi.astype(float), 2, 0)[::2],
              Xi.tolist(), frozen):
        np.testing.assert_allclose(forward(uc, X, V), expected, atol=TOL)
    np.testing.assert_allclose(forward(uc, Xi, V[::1].tolist()), expected, atol=TOL)
    np.testing.assert_allclose(forward(uc, Xi, np.repeat(V, 2)[::2]), expected, atol=TOL)


def test_width_mismatch_refused_on_fast_path():
    uc, _ = circuit(4, seed=2)
    with pytest.raises(ValueError, match="X must have shape"):
        forward(uc, np.zeros((3, 5)), np.zeros(uc.num_parameters))
    with pytest.raises(ValueError, match="values must have shape"):
        forward(uc, np.zeros((3, 4)), np.zeros(uc.num_parameters + 1))


def test_kernel_sine_and_cosine_within_one_ulp_of_libm():
    """The compiled sin / cos of the gate angles against numpy's (libm), over many scales,
    the quadrant boundaries and the hand-over to libm at large angles."""
    from qdensity.execution.unary._kernels import _TRIG_LIMIT, sincos

    rng = np.random.default_rng(7)
    k = np.arange(-40, 41)
    a = np.concatenate([rng.normal(size=20000) * s for s in (1e-9, 0.3, 1.0, 4.0, 50.0, 3e4)]
                       + [k * np.pi / 4, np.nextafter(k * np.pi / 4, np.inf), [0.0, -0.0],
                          [_TRIG_LIMIT, -_TRIG_LIMIT, np.nextafter(_TRIG_LIMIT, 0), 1e9]])
    c, s = sincos(a)
    for got, want in ((c, np.cos(a)), (s, np.sin(a))):
        ulp = np.spacing(np.maximum(np.abs(want), np.finfo(float).tiny))
        assert np.all(np.abs(got - want) <= ulp)
    np.testing.assert_array_equal(sincos(np.array([0.0]))[0], [1.0])


@pytest.mark.parametrize("B", [32, 64, 150])
def test_literal_block_widths(monkeypatch, B):
    """Blocks of 64 and 32 columns (the kernels' loops of literal length), and 150 columns in
    calls of 64, 64 and 22: outputs and dL/dX against the dense product, the summed gradient
    against the per-example kernel's sum."""
    monkeypatch.setenv(_unary_threads.ENV, "1")
    monkeypatch.setattr(_compiled, "_SMALL", 0)
    uc, pairs = circuit(9, seed=B)
    rng = np.random.default_rng(B)
    X, GY = rng.normal(size=(B, 9)), rng.normal(size=(B, 9))
    V = rng.normal(size=uc.num_parameters)
    O = dense(9, pairs, uc.angles(V))
    np.testing.assert_allclose(forward(uc, X, V), X @ O.T, atol=TOL)
    g_sum, g_x = vjp(uc, X, V, GY, reduce="sum")
    g_each, g_x_each = vjp(uc, X, V, GY)
    np.testing.assert_allclose(g_x, GY @ O, atol=TOL)
    np.testing.assert_array_equal(g_x, g_x_each)
    np.testing.assert_allclose(g_sum, g_each.sum(axis=0), atol=TOL)


def test_call_sites_pass_no_literal_arguments(monkeypatch):
    """Every path's kernels compile one specialization per argument layout: a literal integer
    passed from one kernel to another (``Literal[int](0)``, its own numba type) would compile
    the callee again, seconds of first-use time each. ``_rotations`` takes its block width as
    a literal on purpose (inlined where called)."""
    from numba import types
    from numba.core.dispatcher import Dispatcher

    from qdensity.execution.unary import _kernels

    uc, _ = circuit(6, seed=3)
    rng = np.random.default_rng(3)
    X, GY = rng.normal(size=(5, 6)), rng.normal(size=(5, 6))
    V = np.repeat(rng.normal(size=uc.num_parameters), 2)[::2]  # strided values
    for small in (True, False):
        if not small:
            monkeypatch.setattr(_compiled, "_SMALL", 0)
        forward(uc, X, V)
        vjp(uc, X, V, GY, reduce="sum")
        vjp(uc, X, V, GY)
    kernels = {name: obj for name, obj in vars(_kernels).items()
               if isinstance(obj, Dispatcher) and name != "_rotations"}
    assert "_trig_slice" in kernels and "_forward_shared" in kernels
    for name, kernel in kernels.items():
        for sig in kernel.signatures:
            assert not any(isinstance(t, types.Literal) for t in sig), (name, sig)
    assert all(sig[0].layout == "C" for sig in kernels["_trig_slice"].signatures)
