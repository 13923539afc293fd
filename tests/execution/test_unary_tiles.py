"""The unary engine's cache-tiled gate order (:mod:`qdensity.execution.unary._tiles`).

The order must be a topological order of the gates (each gate after the earlier gates on both
its rows) for any gate list; run through the compiled kernels it must give the circuit
order's outputs and input gradients bit for bit, parameter gradients to rounding, and the
dense product of Givens matrices; and it must keep the rows of a round-robin circuit in
tiles (fewer rows from outside the L1 budget than the circuit order).
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import pytest
from _givens import dense

from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.execution import _numba
from qdensity.execution import _threads as _unary_threads
from qdensity.execution.unary import UnaryCircuit, _compiled, _tiles, forward, vjp

pytestmark = pytest.mark.skipif(not _numba.available(), reason="numba switched off")


def rr(n):
    return [p for rnd in round_robin_pairs(n) for p in rnd]


def brickwork(n, depth):
    return [(i, i + 1) for d in range(depth) for i in range(d % 2, n - 1, 2)]


def random_pairs(n, G, rng):
    a = rng.integers(0, n, G)
    return list(zip(a.tolist(), ((a + rng.integers(1, n, G)) % n).tolist(), strict=True))


def circuits():
    """Round-robin (even and odd n), brickwork, random, repeated pairs, a ladder of adjacent
    gates and rows no gate touches."""
    rng = np.random.default_rng(5)
    yield 24, rr(24)
    yield 19, rr(19)
    yield 30, brickwork(30, 17)
    yield 40, random_pairs(40, 600, rng)
    yield 13, [(0, 12), (0, 12), (3, 4), (4, 3)] * 20 + random_pairs(13, 90, rng)
    yield 17, [(k, k + 1) for k in range(16)] * 3 + [(16 - k, 15 - k) for k in range(16)]
    yield 50, [(2 * k, 2 * k + 7) for k in range(20)] * 4  # rows 41.. and odd rows < 7: idle



def assert_topological(pairs, order):
    """``order`` is a permutation in which each gate follows the earlier gates on its rows."""
    G = len(pairs)
    assert sorted(order.tolist()) == list(range(G))
    at = np.empty(G, int)
    at[order] = np.arange(G)
    last: dict[int, int] = {}
    for g, (i, j) in enumerate(pairs):
        for r in (i, j):
            if r in last:
                assert at[last[r]] < at[g]
            last[r] = g


def loads(pairs, order, rows):
    """Rows brought in by a least-recently-used cache of ``rows`` rows, per gate."""
    cache: OrderedDict = OrderedDict()
    count = 0
    for g in order:
        for r in pairs[g]:
            if r in cache:
                cache.move_to_end(r)
                continue
            count += 1
            cache[r] = None
            if len(cache) > rows:
                cache.popitem(last=False)
    return count / len(pairs)


@pytest.mark.parametrize("rows", [8, 12, 16, 64])
def test_tile_order_is_topological(rows):
    for n, pairs in circuits():
        order = _tiles.tile_order(UnaryCircuit.from_gates(n, pairs), rows)
        assert_topological(pairs, order)


def test_no_gates_and_one_gate():
    assert _tiles.tile_order(UnaryCircuit.from_gates(20, np.zeros((0, 2), int)), 8).size == 0
    np.testing.assert_array_equal(_tiles.tile_order(UnaryCircuit.from_gates(20, [(3, 17)]), 8),
                                  [0])


def test_round_robin_rows_stay_in_tiles():
    """n = 256 in tiles of 64 rows: about 1 row in 8 gates from outside a 64-row cache, where
    the circuit order brings 2 per gate; a brickwork circuit fares better still."""
    pairs = rr(256)
    order = _tiles.tile_order(UnaryCircuit.from_gates(256, pairs), 64)
    assert loads(pairs, range(len(pairs)), 64) > 1.9
    assert loads(pairs, order, 64) < 0.25
    pairs = brickwork(256, 128)
    order = _tiles.tile_order(UnaryCircuit.from_gates(256, pairs), 32)
    assert loads(pairs, order, 64) < 0.12


@pytest.fixture
def tiled_now(monkeypatch):
    """Tiled orders from the first call, in tiles of 8 rows whatever the batch, on every
    path (small circuits too)."""
    monkeypatch.setattr(_tiles, "AFTER", 0)
    monkeypatch.setattr(_tiles, "tile_rows", lambda row_bytes: 8)
    monkeypatch.setattr(_compiled, "_SMALL", 0)


def run_all(uc, X, V, GY):
    Y = forward(uc, X, V)
    return Y, vjp(uc, X, V, GY), vjp(uc, X, V, GY, reduce="sum", outputs=Y)


@pytest.mark.parametrize("per_row", [False, True])
def test_tiled_runs_match_circuit_order_and_oracle(tiled_now, monkeypatch, per_row):
    """Outputs and dL/dX bit for bit; parameter gradients to rounding; outputs against the
    dense product. Shared and fixed parameters, batches of 1 to 8 columns (one block)."""
    monkeypatch.setenv(_unary_threads.ENV, "1")
    rng = np.random.default_rng(1)
    for n, pairs in circuits():
        G = len(pairs)
        P = max(1, G // 3)
        args = dict(parameter_index=rng.integers(-1, P, G), coefficient=rng.normal(size=G),
                    offset=rng.normal(size=G), num_parameters=P)
        for B in (1, 5, 8):
            X, GY = rng.normal(size=(B, n)), rng.normal(size=(B, n))
            V = rng.normal(size=(B, P) if per_row else P)
            plain = UnaryCircuit.from_gates(n, pairs, **args)
            monkeypatch.setattr(_tiles, "AFTER", 10**18)
            want = run_all(plain, X, V, GY)
            monkeypatch.setattr(_tiles, "AFTER", 0)
            uc = UnaryCircuit.from_gates(n, pairs, **args)
            got = run_all(uc, X, V, GY)
            assert not plain._tilings.by_rows
            assert list(uc._tilings.by_rows) == [8]  # every call ran the tiled circuit
            np.testing.assert_array_equal(got[0], want[0])
            for g, w in zip(got[1:], want[1:], strict=True):
                np.testing.assert_array_equal(g[1], w[1])
                np.testing.assert_allclose(g[0], w[0], rtol=1e-12, atol=1e-12)
            rows = np.broadcast_to(V, (B, P)) if V.ndim == 1 else V
            oracle = np.stack([dense(n, pairs, uc.angles(v)) @ x
                               for x, v in zip(X, rows, strict=True)])
            np.testing.assert_allclose(got[0], oracle, atol=1e-12)


def test_tiled_runs_in_threads(tiled_now, monkeypatch):
    """Column blocks in threads on the tiled circuit: the one-thread bits."""
    monkeypatch.setattr(_unary_threads, "MIN_WORK", 0)
    monkeypatch.setattr(_unary_threads, "MIN_COLUMNS", 1)
    n, pairs = 24, rr(24)
    uc = UnaryCircuit.from_gates(n, pairs)
    rng = np.random.default_rng(2)
    X, GY = rng.normal(size=(16, n)), rng.normal(size=(16, n))
    V = rng.normal(size=uc.num_parameters)
    monkeypatch.setenv(_unary_threads.ENV, "1")
    one = run_all(uc, X, V, GY)
    monkeypatch.setenv(_unary_threads.ENV, "2")
    two = run_all(uc, X, V, GY)
    np.testing.assert_array_equal(two[0], one[0])
    np.testing.assert_array_equal(two[1][0], one[1][0])
    np.testing.assert_array_equal(two[1][1], one[1][1])
    np.testing.assert_allclose(two[2][0], one[2][0], rtol=1e-13, atol=1e-13)


def test_tiled_order_once_the_circuit_has_carried_enough_columns(monkeypatch):
    monkeypatch.setattr(_tiles, "AFTER", 100)
    uc = UnaryCircuit.from_gates(300, rr(300))
    assert _tiles.tiled(uc, 512, 64) is uc  # 64 columns carried
    assert _tiles.tiled(uc, 512, 30) is uc  # 94
    assert not uc._tilings.by_rows
    t = _tiles.tiled(uc, 512, 30)  # 124: tiles of 64 rows of 64 columns
    assert t is not uc and list(uc._tilings.by_rows) == [64]
    assert _tiles.tiled(uc, 500, 1) is t  # 65 rows: rounded down to 64, the same order
    assert _tiles.tiled(uc, 1024, 1) is not t  # 32 rows: another order
    order = _tiles.tile_order(uc, 64)
    for name in ("first", "second", "parameter_index", "coefficient", "offset"):
        np.testing.assert_array_equal(getattr(t, name), getattr(uc, name)[order])
    assert t.parameters is uc.parameters and t.num_gates == uc.num_gates
    small = UnaryCircuit.from_gates(64, rr(64))  # 64 rows fit in a tile: circuit order
    assert _tiles.tiled(small, 512, 10**6) is small
    assert _tiles.tiled(uc, 8 * 10**4, 10**6) is uc  # rows too wide for 8 in a tile


def test_tile_rows():
    assert _tiles.tile_rows(512) == 64
    assert _tiles.tile_rows(256) == 128
    assert _tiles.tile_rows(1024) == 32
    assert _tiles.tile_rows(8 * 50) == 64  # 81 rows of 50 columns: a power of two below
    assert _tiles.tile_rows(10**6) == 1
