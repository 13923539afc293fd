"""Qubit layout of the adjoint engine's compiled kernels: gates kept off the lowest bits.

The kernels of :mod:`._kernels_planar` vectorise over blocks of contiguous
amplitudes, ``2**p`` long for a gate whose lowest qubit (or control) sits at bit ``p``. On bits
0-2 the blocks are 1-4 amplitudes and a gate costs 5-10 times a gate on a high bit, which made
the gates on qubits 0-2 (a third of a 16-qubit non-commuting circuit) most of its time;
on bit 3 a block of 8 still costs 2-3 times a long one.

So the kernels run the circuit in a moving layout: logical qubit ``q`` lives at bit
``phys[q]``, and before a gate that touches a qubit at a bit below :data:`LOW_BITS`, one
permutation of the amplitudes (:func:`._kernels_planar.permute`, one pass)
parks on the low bits the qubits whose next gate is furthest away (Belady's rule) and brings
the needed ones up. The gate tables are written in the layout current at each gate, and a
last permutation restores ``phys[q] = q``, so states, observables and gradients are unchanged.
At n = 16 this is one permutation for every 3-7 gates that would have run on short blocks
(non-commuting: 50 permutations for 472 gates); a whole value-and-gradient call took 0.5-0.9
times as long at n = 14-18 (interleaved, batch 1), and 0.85-1.05 times at n = 20, where
every pass streams the state from memory.
"""

from __future__ import annotations

import numpy as np

__all__ = ["LOW_BITS", "MIN_QUBITS", "plan", "tile"]

#: Bit positions kept free of gates (every block then has 2**LOW_BITS amplitudes or more). 4
#: beat 3 and 5 on every family at n = 16 (3: blocks of 8 still pay for their slices).
LOW_BITS = 4
#: Narrower circuits keep the identity layout (their gates cost little next to a call).
MIN_QUBITS = 10


def plan(masks: list[int], n: int, low: int | None = None):
    """The layout of every operation and the permutations between them.

    A layout is always a set of disjoint exchanges ``(b, h)`` of a low bit ``b`` with the home
    bit ``h >= low`` of the qubit ``h`` parked on it (qubit ``b`` then waits at bit ``h``), so
    a change of layout, and the return to the identity at the end, moves at most ``3 low``
    bits: one pass over tiles of at most ``2**(3 low)`` amplitudes.

    Parameters
    ----------
    masks : list of int
        Logical qubits each operation touches (bit ``q`` for qubit ``q``), in circuit order.
    n : int
        Qubits.
    low : int, optional
        Bits to keep free of gates (default :data:`LOW_BITS`).

    Returns
    -------
    list
        In execution order, ``("op", i, phys)`` (operation ``i`` in the layout ``phys``, a
        tuple: logical qubit to bit) and ``("perm", dest)`` (a permutation: bit ``b`` moves
        to ``dest[b]``); the last permutation (if any) restores the identity layout.
    """
    low = LOW_BITS if low is None else low
    ident = tuple(range(n))
    need = max((bin(m).count("1") for m in masks), default=0)
    if low <= 0 or n < 2 * low + need:
        return [("op", i, ident) for i in range(len(masks))]
    # nxt[i, q]: the first operation at or after i that touches q (len(masks) if none)
    nxt = np.full((len(masks) + 1, n), len(masks), dtype=np.int64)
    for i in range(len(masks) - 1, -1, -1):
        nxt[i] = nxt[i + 1]
        for q in range(n):
            if masks[i] >> q & 1:
                nxt[i, q] = i
    guest = list(range(low))  # the qubit on low bit b (b itself: at home)
    phys = ident
    out: list = []
    for i, m in enumerate(masks):
        if any(m >> q & 1 and phys[q] < low for q in range(n)):
            new: list[int] = []
            for b in range(low):  # park the qubit used last; on a tie, the one already there
                cands = [g for g in [b, *range(low, n)] if not m >> g & 1 and g not in new]
                new.append(min(cands, key=lambda g: (-int(nxt[i, g]), g != guest[b], g)))
            guest = new
            layout = list(ident)
            for b, g in enumerate(guest):
                layout[g], layout[b] = b, g
            out.append(("perm", _dest(phys, layout)))
            phys = tuple(layout)
        out.append(("op", i, phys))
    if phys != ident:
        out.append(("perm", _dest(phys, list(ident))))
    return out


def _dest(old, new) -> np.ndarray:
    """Bit ``old[q]`` moves to bit ``new[q]``."""
    dest = np.empty(len(old), dtype=np.int64)
    for q, b in enumerate(old):
        dest[b] = new[q]
    return dest


def tile(dest: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """A bit permutation as tiles: ``(free, offs, src, back)``. A tile holds the amplitudes that
    differ only on bits 0-2 and on the moved bits (ascending), entry ``e`` at offset
    ``offs[e]`` (so runs of 8 entries are contiguous); ``free`` is the mask of the other
    bits. The permutation sets entry ``e`` to the old entry ``src[e]``; its inverse
    to ``back[e]``."""
    n = dest.size
    bits = sorted(set(range(min(3, n))) | {b for b in range(n) if dest[b] != b})
    where = {b: j for j, b in enumerate(bits)}
    D = 1 << len(bits)
    u = np.arange(D)
    offs = np.zeros(D, dtype=np.int64)
    dst = np.zeros(D, dtype=np.int64)
    for j, b in enumerate(bits):
        bit = (u >> j) & 1
        offs |= bit << b
        dst |= bit << where[int(dest[b])]
    src = np.empty_like(dst)
    src[dst] = u
    free = ((1 << n) - 1) & ~int(offs[-1])
    return free, offs, src, dst
