"""Many Pauli strings conjugated at once by a layer of one two-qubit unitary on disjoint pairs.

:func:`qdensity.analysis.pauli.conjugate_two_qubit` conjugates one operator by one gate; a
gradient of an RBS moment with ``n`` unary outputs needs ``n`` operators conjugated by the
whole ``RBS(pi/4)`` layer of Supp. F.3, which one array pass per round does here: each round
takes, for every string, the first layer pair it touches that was not yet applied, and
expands the string through that pair's 16 x 16 transfer matrix (rows of the strings that
touch no pending pair pass unchanged). Strings touching one pair (every RBS gradient string)
take one round.
"""

from __future__ import annotations

import numpy as np

from qdensity.analysis.pauli import _TRANSFER_CACHE, _X_OF, _Z_OF, _transfer_matrix

__all__ = ["conjugate_by_layer"]


def conjugate_by_layer(x: np.ndarray, z: np.ndarray, coeffs: np.ndarray, unitary: np.ndarray,
                       pairs: np.ndarray, atol: float = 1e-12):
    """``U_L P U_L^dagger`` for every string ``P`` (row), ``U_L`` the tensor product of
    ``unitary`` on each pair of ``pairs``.

    Parameters
    ----------
    x, z : numpy.ndarray of bool, shape (S, n)
        Symplectic bits of the strings (phase 0: ``Y`` where both are set).
    coeffs : numpy.ndarray of complex, shape (S,)
    unitary : numpy.ndarray, shape (4, 4)
        Qiskit's convention (index ``q_0 + 2 q_1`` for a pair ``(q_0, q_1)``).
    pairs : numpy.ndarray of int, shape (L, 2)
        Disjoint qubit pairs.
    atol : float
        Transfer-matrix entries below it are dropped.

    Returns
    -------
    (x, z, coeffs, source)
        The output strings (equal strings are not merged) and, per output row, the input
        row it came from, shape (S',).
    """
    mat = np.asarray(unitary, dtype=complex)
    key = mat.tobytes()
    tm = _TRANSFER_CACHE.get(key)
    if tm is None:
        tm = _TRANSFER_CACHE.setdefault(key, _transfer_matrix(mat))
    pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    q0, q1 = pairs[:, 0], pairs[:, 1]
    x, z = np.array(x, dtype=bool), np.array(z, dtype=bool)
    coeffs = np.asarray(coeffs, dtype=complex)
    source = np.arange(x.shape[0])
    done = np.zeros((x.shape[0], pairs.shape[0]), dtype=bool)
    while x.shape[0] and pairs.shape[0]:
        code = x.astype(np.intp) + 3 * z - 2 * (x & z)  # I, X, Y, Z -> 0, 1, 2, 3
        b = 4 * code[:, q0] + code[:, q1]
        pending = (b != 0) & ~done
        rows = np.flatnonzero(pending.any(axis=1))
        if not rows.size:
            break
        lp = pending[rows].argmax(axis=1)  # the first pending pair of each such string
        bb = b[rows, lp]
        t, a = np.nonzero(np.abs(tm[:, bb]).T > atol)  # string t of rows -> pair code a
        src_rows = rows[t]
        nx, nz = x[src_rows], z[src_rows]
        r = np.arange(t.size)
        nx[r, q0[lp[t]]], nz[r, q0[lp[t]]] = _X_OF[a // 4], _Z_OF[a // 4]
        nx[r, q1[lp[t]]], nz[r, q1[lp[t]]] = _X_OF[a % 4], _Z_OF[a % 4]
        ndone = done[src_rows]
        ndone[r, lp[t]] = True
        keep = np.ones(x.shape[0], dtype=bool)
        keep[rows] = False
        x = np.concatenate([x[keep], nx])
        z = np.concatenate([z[keep], nz])
        coeffs = np.concatenate([coeffs[keep], coeffs[src_rows] * tm[a, bb[t]]])
        source = np.concatenate([source[keep], source[src_rows]])
        done = np.concatenate([done[keep], ndone])
    return x, z, coeffs, source
