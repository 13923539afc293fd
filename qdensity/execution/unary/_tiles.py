"""Cache tiling of the unary engine's gate order: the gates reordered so that the rows they
touch stay in the core's L1 cache.

The compiled kernels (:mod:`._kernels`) rotate two rows of ``m`` batch columns per gate. In
circuit order the gates of a round-robin or brickwork circuit walk over all ``n`` rows before
they come back to one, so once ``n`` rows no longer fit in L1 (``n * 8 m`` bytes: 48 KB is 96
rows of 64 doubles) every gate reads and writes its two rows from L2, which then bounds the
rate. Any order in which each gate comes after the earlier gates on its two rows gives every
row the same rotations in the same order, hence the same numbers bit for bit (a parameter
shared by several gates sums its gate gradients in another order: last bits); this module
picks one that works in tiles of at most ``R`` rows.

A tile grows from the ready gate (all earlier gates on its rows done) of lowest (ASAP layer,
index). Each step adds the rows of one more ready gate -- the lowest adjacent one (one row
already in the tile), else the lowest ready gate of all -- and then runs every gate that
becomes ready with both rows in the tile, until the tile holds ``R`` rows. For a round-robin
circuit at ``R = 64`` about one row in eight gates comes from L2 (two per gate in circuit
order); a random gate list keeps about one in one. Computing the order costs about the work
of a few hundred batch columns through the circuit, so :func:`tiled` computes it once a
circuit has carried :data:`AFTER` columns and keeps it with the circuit.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution import _numba

__all__: list[str] = []

# Bytes of rows a tile may hold: two thirds of a 48 KB L1 (the cosines, sines and row indices
# stream through the rest); 32 KB is 64 rows of 64 doubles.
TILE_BYTES = 32 * 1024
# Batch columns a circuit carries (summed over its calls) before its tiled order is computed:
# the order costs about as much as 500 columns through the untiled kernels, so a circuit run
# once is not slowed, and one run often pays it back within a few calls.
AFTER = 512
MIN_ROWS = 8  # smallest tile worth reordering for


class Tilings:
    """A circuit's tiled gate orders (by tile rows) and the columns it has carried."""

    def __init__(self) -> None:
        self.columns = 0
        self.by_rows: dict[int, object] = {}


def tile_rows(row_bytes: int) -> int:
    """Rows of ``row_bytes`` bytes a tile holds: ``TILE_BYTES // row_bytes`` rounded down to a
    power of two (few distinct orders per circuit)."""
    rows = max(1, TILE_BYTES // max(row_bytes, 1))
    return 1 << (rows.bit_length() - 1)


def tiled(compiled, row_bytes: int, columns: int):
    """The circuit to run for blocks of rows ``row_bytes`` bytes wide: ``compiled`` itself, or
    the same circuit with its gates in tiled order once that pays.

    Parameters
    ----------
    compiled : UnaryCircuit
    row_bytes : int
        Bytes of one row of the work arrays (``8 m`` for ``m`` columns, twice that in the
        reverse pass, which holds activations and gradients).
    columns : int
        Batch columns of this call (counted towards :data:`AFTER`).

    Returns
    -------
    UnaryCircuit
        Same parameters and gates; only the order of the gates may differ.
    """
    rows = tile_rows(row_bytes)
    if not _numba.available() or rows < MIN_ROWS or compiled.num_qubits <= rows:
        return compiled  # every row fits: the circuit order is as good
    state = compiled._tilings
    state.columns += columns
    found = state.by_rows.get(rows)
    if found is None:
        if state.columns < AFTER:
            return compiled
        found = state.by_rows[rows] = reorder(compiled, tile_order(compiled, rows))
    return found


def tile_order(compiled, rows: int) -> np.ndarray:
    """The tiled order of ``compiled``'s gates for tiles of ``rows`` rows (a permutation)."""
    first, second = compiled._gate_rows
    return _order(compiled.num_qubits, first, second, rows)


def reorder(compiled, order: np.ndarray):
    """``compiled`` with its gates taken in ``order`` (a topological order of its gates)."""
    return type(compiled)._from_checked(
        compiled.num_qubits, compiled.parameters, compiled.first[order],
        compiled.second[order], compiled.parameter_index[order], compiled.coefficient[order],
        compiled.offset[order])


if _numba.available():
    jit = _numba.jit

    @jit(nogil=True)
    def _push(heap, size, key):  # binary min-heap of int64 keys in heap[:size]
        i = size
        heap[i] = key
        while i > 0:
            up = (i - 1) >> 1
            if heap[up] <= heap[i]:
                break
            heap[up], heap[i] = heap[i], heap[up]
            i = up
        return size + 1

    @jit(nogil=True)
    def _pop(heap, size):  # the smallest key and the new size
        top = heap[0]
        size -= 1
        heap[0] = heap[size]
        i = 0
        while True:
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and heap[c + 1] < heap[c]:
                c += 1
            if heap[i] <= heap[c]:
                break
            heap[c], heap[i] = heap[i], heap[c]
            i = c
        return top, size

    @jit(nogil=True)
    def _order(n, first, second, R):
        G = first.shape[0]
        # key = ASAP layer * G + index (the heaps' order); each row's gates in circuit order
        depth = np.zeros(n, np.int64)
        key = np.empty(G, np.int64)
        start = np.zeros(n + 1, np.int64)
        for g in range(G):
            a, b = first[g], second[g]
            lv = max(depth[a], depth[b])
            key[g] = lv * G + g
            depth[a] = lv + 1
            depth[b] = lv + 1
            start[a + 1] += 1
            start[b + 1] += 1
        start = np.cumsum(start)
        on_row = np.empty(2 * G, np.int64)
        nxt = start[:-1].copy()  # per row: position in on_row of its next gate to run
        for g in range(G):
            for r in (first[g], second[g]):
                on_row[nxt[r]] = g
                nxt[r] += 1
        nxt[:] = start[:-1]
        state = np.zeros(G, np.int8)  # 0 waiting, 1 ready, 2 done
        ready = np.empty(G, np.int64)  # heap of the ready gates' keys (stale ones skipped)
        near = np.empty(G + 2 * n, np.int64)  # heap: ready gates with one row in the tile
        todo = np.empty(G + 2 * n, np.int64)  # stack: ready gates with both rows in the tile
        tile_of = np.full(n, -1, np.int64)  # the tile a row was last taken into
        order = np.empty(G, np.int64)
        n_ready = 0
        for g in range(G):
            a, b = first[g], second[g]
            if on_row[nxt[a]] == g and nxt[b] < start[b + 1] and on_row[nxt[b]] == g:
                state[g] = 1
                n_ready = _push(ready, n_ready, key[g])
        done = 0
        tile = 0
        while done < G:
            n_near = 0
            size = 0
            pick = -1
            while True:
                if pick < 0:  # nothing adjacent: the lowest ready gate
                    while n_ready > 0 and state[ready[0] % G] != 1:
                        _, n_ready = _pop(ready, n_ready)
                    pick = ready[0] % G
                new = (tile_of[first[pick]] != tile) + (tile_of[second[pick]] != tile)
                if size + new > R:
                    break
                top = 0
                for r in (first[pick], second[pick]):
                    if tile_of[r] == tile:
                        continue
                    tile_of[r] = tile
                    size += 1
                    if nxt[r] < start[r + 1]:
                        h = on_row[nxt[r]]
                        if state[h] == 1:
                            other = second[h] if first[h] == r else first[h]
                            if tile_of[other] == tile:
                                todo[top] = h
                                top += 1
                            else:
                                n_near = _push(near, n_near, key[h])
                while top > 0:  # run what the tile's rows allow
                    top -= 1
                    g = todo[top]
                    if state[g] != 1:
                        continue
                    state[g] = 2
                    order[done] = g
                    done += 1
                    a, b = first[g], second[g]
                    nxt[a] += 1
                    nxt[b] += 1
                    for r in (a, b):
                        if nxt[r] == start[r + 1]:
                            continue
                        h = on_row[nxt[r]]
                        other = second[h] if first[h] == r else first[h]
                        if state[h] == 0 and on_row[nxt[other]] == h:
                            state[h] = 1
                            n_ready = _push(ready, n_ready, key[h])
                            inside = (tile_of[r] == tile) + (tile_of[other] == tile)
                            if inside == 2:
                                todo[top] = h
                                top += 1
                            elif inside == 1:
                                n_near = _push(near, n_near, key[h])
                if size >= R or done == G:
                    break
                pick = -1
                while n_near > 0:
                    k, n_near = _pop(near, n_near)
                    if state[k % G] == 1:
                        pick = k % G
                        break
            tile += 1
        return order
