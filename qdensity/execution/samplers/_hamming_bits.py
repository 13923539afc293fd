"""Drawn outcomes to packed clbits, and readout flips on the packed bytes.

A shot of a weight-``k`` circuit sets ``k`` qubits; its clbits are written straight into
packed bytes (clbit ``c`` is bit ``c % 8`` of byte ``c // 8``, little-endian) without a
``(shots, num_clbits)`` boolean array. Readout errors flip bits at sparse random positions:
candidates are the successes of a Bernoulli(``p_max``) sequence over all (shot, clbit) pairs
(geometric gaps), each kept with probability ``p(bit) / p_max`` (thinning); every pair then
flips independently with its own ``p(1|0)`` or ``p(0|1)``, exactly, in ``O(shots x clbits x
p_max)`` work.
"""

from __future__ import annotations

import numpy as np


def clbits_of_qubits(measured: list, num_qubits: int) -> np.ndarray:
    """``(num_qubits, s)`` the clbits measuring each qubit, padded with -1."""
    per: list[list[int]] = [[] for _ in range(num_qubits)]
    for c, q in enumerate(measured):
        if q is not None:
            per[q].append(c)
    width = max((len(x) for x in per), default=0)
    out = np.full((num_qubits, max(width, 1)), -1, dtype=np.int64)
    for q, cs in enumerate(per):
        out[q, : len(cs)] = cs
    return out


def pack_outcomes(outcome_qubits: np.ndarray, draws: np.ndarray, clbit_table: np.ndarray,
                  num_clbits: int) -> np.ndarray:
    """Packed clbits ``(N, ceil(num_clbits / 8))`` of the drawn outcomes ``draws`` (N,)."""
    nbytes = (num_clbits + 7) // 8
    out = np.zeros((draws.size, nbytes), dtype=np.uint8)
    if not nbytes or outcome_qubits.shape[1] == 0:
        return out
    held = outcome_qubits[draws]  # (N, k)
    shot = np.arange(draws.size)
    for col in range(held.shape[1]):
        cl = clbit_table[held[:, col]]  # (N, s)
        for slot in range(cl.shape[1]):
            c = cl[:, slot]
            ok = c >= 0
            rows, c = (shot, c) if ok.all() else (shot[ok], c[ok])
            # one clbit per shot in this pass: no (shot, byte) repeats
            out[rows, c >> 3] |= (1 << (c & 7)).astype(np.uint8)
    return out


def _bernoulli_positions(total: int, p: float, rng: np.random.Generator) -> np.ndarray:
    """Positions in ``range(total)`` of the successes of i.i.d. Bernoulli(p) trials."""
    if p <= 0 or total == 0:
        return np.zeros(0, dtype=np.int64)
    if p >= 1:
        return np.arange(total, dtype=np.int64)
    parts, at = [], -1
    while True:
        batch = int(total * p * 1.1) + 64
        gaps = rng.geometric(p, size=batch)  # trials up to and including the next success
        pos = at + np.cumsum(gaps)
        if pos[-1] >= total:
            parts.append(pos[pos < total])
            break
        parts.append(pos)
        at = int(pos[-1])
    return np.concatenate(parts).astype(np.int64)


def flip_readout(packed: np.ndarray, cols: np.ndarray, p01: np.ndarray, p10: np.ndarray,
                 rng: np.random.Generator) -> None:
    """Flip packed clbits in place: clbit ``cols[j]`` reads 1 for 0 with ``p01[j]`` and 0 for 1
    with ``p10[j]``, independently per shot and clbit."""
    p_max = float(max(p01.max(initial=0.0), p10.max(initial=0.0)))
    m = cols.size
    pos = _bernoulli_positions(packed.shape[0] * m, p_max, rng)
    if not pos.size:
        return
    shot, j = np.divmod(pos, m)
    c = cols[j]
    byte, bit = c >> 3, (c & 7).astype(np.uint8)
    value = (packed[shot, byte] >> bit) & 1
    keep = rng.random(pos.size) * p_max < np.where(value == 1, p10[j], p01[j])
    np.bitwise_xor.at(packed, (shot[keep], byte[keep]),
                      (np.uint8(1) << bit[keep]).astype(np.uint8))
