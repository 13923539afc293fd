"""Compiled layer loop of the unary engine (numba).

The Givens rotations of a :class:`~qdensity.execution.unary.UnaryCircuit` applied gate by
gate, in circuit order, to the rows of ``Z`` (n, B) in place: ``Z[i], Z[j] <- c Z[i] - s Z[j],
s Z[i] + c Z[j]`` (the paper's RBS on unary amplitudes; docs/design.md, "RBS"). A row is a
contiguous run of ``B`` numbers, so each gate is one vectorised loop, with no per-layer
gathers, scatters or sparse-matrix bookkeeping. Without numba (or with ``QDENSITY_NUMBA=0``)
the engine keeps its numpy/scipy layer kernels (:mod:`qdensity.execution.unary._plan`), which
give the same numbers to rounding.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution import _numba

__all__ = ["available", "givens"]


def available() -> bool:
    """True when the compiled kernels run (see :func:`qdensity.execution._numba.available`)."""
    return _numba.available()


if _numba.available():
    jit = _numba.jit

    @jit()
    def _shared(Z, first, second, cos, sin):
        B = Z.shape[1]
        for g in range(first.shape[0]):
            c = cos[g]
            s = sin[g]
            zi = Z[first[g]]
            zj = Z[second[g]]
            for b in range(B):
                a = zi[b]
                d = zj[b]
                zi[b] = c * a - s * d
                zj[b] = s * a + c * d

    @jit()
    def _per_column(Z, first, second, cos, sin):
        B = Z.shape[1]
        for g in range(first.shape[0]):
            zi = Z[first[g]]
            zj = Z[second[g]]
            cg = cos[g]
            sg = sin[g]
            for b in range(B):
                a = zi[b]
                d = zj[b]
                zi[b] = cg[b] * a - sg[b] * d
                zj[b] = sg[b] * a + cg[b] * d


def givens(Z: np.ndarray, compiled, angles: np.ndarray) -> np.ndarray:
    """``O(angles) @ Z`` in place on ``Z`` (n, B), C-contiguous float64, and returned.

    Parameters
    ----------
    Z : numpy.ndarray, shape (n, B)
    compiled : UnaryCircuit
    angles : numpy.ndarray, shape (G,) shared by the columns, or (G, B) one per column
    """
    first = np.ascontiguousarray(compiled.first, dtype=np.int64)
    second = np.ascontiguousarray(compiled.second, dtype=np.int64)
    run = _shared if angles.ndim == 1 else _per_column
    run(Z, first, second, np.cos(angles), np.sin(angles))
    return Z
