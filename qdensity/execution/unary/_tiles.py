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

A tile grows from the gate of lowest (ASAP layer, index) not yet run (it is ready: all
earlier gates on its rows have run). Each step adds the rows of one more ready gate -- the
first found of those with one row in the tile (a queue), else the lowest gate not run --
and then runs every gate that becomes ready with both rows in the tile, until the tile holds
``R`` rows. For a round-robin circuit at ``n = 1024``, ``R = 64``, a cache of 80 rows loads
about one row per ten gates (two per gate in circuit order); a random gate list keeps
about one per gate. Computing the order costs about the work of a few hundred batch columns
through the circuit (0.05 s at ``n = 1024``), so :func:`tiled` computes it once a circuit
has carried :data:`AFTER` columns, and keeps it with the circuit.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution import _numba

__all__: list[str] = []

# Bytes of rows a tile may hold: two thirds of a 48 KB L1 (the cosines, sines and row indices
# stream through the rest); 32 KB is 64 rows of 64 doubles.
TILE_BYTES = 32 * 1024
# Batch columns a circuit carries (summed over its calls) before its tiled order is computed:
# the order costs about as much as 200 columns through the untiled kernels, so a circuit run
# once is not slowed, and one run often pays it back within a few calls.
AFTER = 256
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

    # (Loops rather than numpy calls on slices, np.full or bool arrays: those tripled the
    # compile time.)
    @jit(nogil=True, inline="always")
    def _ready(h, other, tile, tile_of, todo, top, queued, near, tail):
        # a ready gate h (its other row: other): to run now if both rows are in the tile,
        # else queued once per tile as adjacent; the new stack and queue ends
        if tile_of[other] == tile:
            todo[top] = h
            top += 1
        elif queued[h] != tile:
            queued[h] = tile
            near[tail] = h
            tail += 1
        return top, tail

    @jit(nogil=True)
    def _order(n, first, second, R):
        G = first.shape[0]
        depth = np.zeros(n, np.int64)
        level = np.empty(G, np.int64)  # ASAP layer
        start = np.zeros(n + 1, np.int64)  # row r's gates: on_row[start[r]:start[r + 1]]
        for g in range(G):
            a, b = first[g], second[g]
            lv = max(depth[a], depth[b])
            level[g] = lv
            depth[a] = lv + 1
            depth[b] = lv + 1
            start[a + 1] += 1
            start[b + 1] += 1
        for r in range(n):
            start[r + 1] += start[r]
        # the gates by (layer, index), a counting sort: the first one not done is ready
        at = np.zeros(G + 2, np.int64)
        for g in range(G):
            at[level[g] + 1] += 1
        for k in range(G):
            at[k + 1] += at[k]
        by_level = np.empty(G, np.int64)
        for g in range(G):
            by_level[at[level[g]]] = g
            at[level[g]] += 1
        on_row = np.empty(2 * G, np.int64)
        nxt = np.empty(n, np.int64)  # per row: where in on_row its next gate to run is
        for r in range(n):
            nxt[r] = start[r]
        for g in range(G):
            for k in range(2):
                r = first[g] if k == 0 else second[g]
                on_row[nxt[r]] = g
                nxt[r] += 1
        tile_of = np.empty(n, np.int64)  # the tile a row was last taken into
        for r in range(n):
            nxt[r] = start[r]
            tile_of[r] = -1
        queued = np.empty(G, np.int64)  # the tile whose queue last took the gate
        for g in range(G):
            queued[g] = -1
        done_at = np.zeros(G, np.int64)  # 1 once the gate is in the order
        near = np.empty(G + 2 * n, np.int64)  # queue: ready gates with one row in the tile
        todo = np.empty(G + 2, np.int64)  # stack: ready gates with both rows in the tile
        order = np.empty(G, np.int64)
        done = 0
        lowest = 0
        tile = 0
        while done < G:
            head = 0
            tail = 0
            size = 0
            pick = -1
            while True:
                if pick < 0:  # nothing adjacent: the lowest gate not done
                    while done_at[by_level[lowest]]:
                        lowest += 1
                    pick = by_level[lowest]
                new = (tile_of[first[pick]] != tile) + (tile_of[second[pick]] != tile)
                if size + new > R:
                    break
                top = 0
                for k in range(2):  # its rows join the tile; their ready gates queue
                    r = first[pick] if k == 0 else second[pick]
                    if tile_of[r] == tile:
                        continue
                    tile_of[r] = tile
                    size += 1
                    if nxt[r] == start[r + 1]:
                        continue
                    h = on_row[nxt[r]]
                    other = second[h] if first[h] == r else first[h]
                    if on_row[nxt[other]] != h:
                        continue  # not ready
                    top, tail = _ready(h, other, tile, tile_of, todo, top, queued, near, tail)
                while top > 0:  # run every gate the tile's rows allow
                    top -= 1
                    g = todo[top]
                    if done_at[g]:
                        continue
                    done_at[g] = 1
                    order[done] = g
                    done += 1
                    nxt[first[g]] += 1
                    nxt[second[g]] += 1
                    for k in range(2):
                        r = first[g] if k == 0 else second[g]
                        if nxt[r] == start[r + 1]:
                            continue
                        h = on_row[nxt[r]]
                        other = second[h] if first[h] == r else first[h]
                        if on_row[nxt[other]] != h or (k == 1 and other == first[g]):
                            continue  # not ready, or g's other row found it already
                        top, tail = _ready(h, other, tile, tile_of, todo, top, queued, near,
                                           tail)
                if size >= R or done == G:
                    break
                pick = -1
                while head < tail:  # the first adjacent gate still to run
                    h = near[head]
                    head += 1
                    if not done_at[h]:
                        pick = h
                        break
            tile += 1
        return order
