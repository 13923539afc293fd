"""GF(2) linear algebra on the symplectic bits ``(x | z)`` of Pauli strings.

The symplectic form is bilinear, so questions about every pair of many strings (do they all
commute?) are settled on a basis of their span (at most ``2 n`` rows, however many strings).
"""

from __future__ import annotations

import numpy as np
from qiskit.quantum_info import PauliList

__all__: list[str] = []


def span_basis(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A basis of the GF(2) span of the rows ``(x | z)``, by elimination on packed bits.

    At most ``2 n`` rows however many terms: the symplectic form is bilinear, so every pair of
    terms commutes iff every pair of basis vectors does.
    """
    n = x.shape[1]
    rows = np.packbits(np.concatenate([x, z], axis=1), axis=1)
    live = np.arange(rows.shape[0])
    basis = []
    for c in range(2 * n):
        if not live.size:
            break
        has = np.flatnonzero(rows[live, c >> 3] & (0x80 >> (c & 7)))
        if not has.size:
            continue
        pivot = live[has[0]]
        rows[live[has[1:]]] ^= rows[pivot]
        basis.append(rows[pivot])
        live = np.delete(live, has[0])
    if not basis:
        return np.zeros((0, n), bool), np.zeros((0, n), bool)
    bits = np.unpackbits(np.array(basis), axis=1, count=2 * n).astype(bool)
    return bits[:, :n], bits[:, n:]


def independent_rows(pl: PauliList) -> PauliList:
    """A maximal GF(2)-independent subset of the rows, the first ones in order (phases
    dropped)."""
    n = pl.num_qubits
    mat = np.concatenate([pl.x, pl.z], axis=1).astype(np.uint8)
    basis: list[np.ndarray] = []
    pivcols: list[int] = []
    keep: list[int] = []
    for idx, row in enumerate(mat):
        v = row.copy()
        for b, c in zip(basis, pivcols, strict=True):
            if v[c]:
                v ^= b
        nz = np.flatnonzero(v)
        if nz.size:
            basis.append(v)
            pivcols.append(int(nz[0]))
            keep.append(idx)
    if not keep:
        return PauliList.from_symplectic(np.zeros((0, n), bool), np.zeros((0, n), bool))
    return PauliList.from_symplectic(pl.z[keep], pl.x[keep])
