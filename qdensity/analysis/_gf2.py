"""GF(2) linear algebra on the symplectic bits ``(x | z)`` of Pauli strings.

The symplectic form is bilinear, so questions about every pair of many strings (do they all
commute?) are settled on a basis of their span (at most ``2 n`` rows, however many strings).
"""

from __future__ import annotations

import numpy as np
from qiskit.quantum_info import PauliList

__all__ = ["anticommutation"]


def anticommutation(xa: np.ndarray, za: np.ndarray, xb: np.ndarray | None = None,
                    zb: np.ndarray | None = None) -> np.ndarray:
    """Anticommutation of every pair of Pauli operators as one GF(2) product.

    ``A[s, t] = x_s . z'_t + z_s . x'_t (mod 2)``, computed on the symplectic bits packed 64
    to a word: an AND, an XOR over the words and one popcount per pair (exact).

    Parameters
    ----------
    xa, za : numpy.ndarray of bool, shape (m, n)
        Symplectic bits of the first set.
    xb, zb : numpy.ndarray of bool, shape (k, n), optional
        Of the second set; default the first.

    Returns
    -------
    numpy.ndarray of bool, shape (m, k)
        True where the operators anticommute.

    Examples
    --------
    >>> from qiskit.quantum_info import PauliList
    >>> pl = PauliList(["XI", "ZI", "IZ"])
    >>> anticommutation(pl.x, pl.z).astype(int).tolist()
    [[0, 1, 0], [1, 0, 0], [0, 0, 0]]
    """
    if xb is None:
        xb, zb = xa, za
    a = _packed_words(np.concatenate([xa, za], axis=1))
    b = _packed_words(np.concatenate([zb, xb], axis=1))
    out = np.empty((a.shape[0], b.shape[0]), dtype=bool)
    if not out.size:
        return out
    # the parity of popcount(a & b) over the words: XOR the words, then one popcount; rows of
    # ``a`` in chunks of about 2**22 word products (no BLAS: 64 bits per operation, and no
    # threads, which on a busy machine cost more than they save)
    step = max(1, (1 << 22) // max(1, b.shape[0] * a.shape[1]))
    for lo in range(0, a.shape[0], step):
        words = a[lo:lo + step, None, :] & b[None, :, :]
        out[lo:lo + step] = np.bitwise_count(np.bitwise_xor.reduce(words, axis=2)) & 1
    return out


def _packed_words(bits: np.ndarray) -> np.ndarray:
    """Rows of bits (m, w) as rows of 64-bit words (m, ceil(w / 64))."""
    packed = np.packbits(np.asarray(bits, dtype=bool), axis=1)
    pad = (-packed.shape[1]) % 8
    if pad or not packed.shape[1]:
        packed = np.pad(packed, ((0, 0), (0, pad if packed.shape[1] else 8)))
    return np.ascontiguousarray(packed).view(np.uint64)


def all_commute(x: np.ndarray, z: np.ndarray) -> bool:
    """Whether the Paulis with rows ``(x | z)`` (m, n) commute pairwise: the m x m product, or,
    for many more rows than qubits, the product of a basis of their span (:func:`span_basis`),
    which decides the same (the symplectic form is bilinear) at ``O(m n)``."""
    if x.shape[0] > 8 * max(x.shape[1], 1):
        x, z = span_basis(x, z)
    return not anticommutation(x, z).any()


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
