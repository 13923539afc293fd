"""The kernels of the exact noisy program (:mod:`._noisy_program`): a superoperator on one or
two qubits applied to every row of a batch of density matrices, compiled with numba (core;
``QDENSITY_NUMBA=0`` switches it off here as in the engines, and numpy then computes the same
numbers).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["apply_superop"]


def _numba():
    """numba, imported on first use (importing it costs about a second of CPU, which a plan
    that never simulates a noisy circuit should not pay), or None where it is missing or
    ``QDENSITY_NUMBA`` switches it off (the engines' switch, read as
    :mod:`qdensity.execution._numba` reads it; that module imports numba when imported)."""
    if os.environ.get("QDENSITY_NUMBA", "1").strip().lower() in ("0", "false", "no", "off"):
        return None
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a core dependency
        return None
    return numba


#: numba's floating-point flags for the kernel: sums may be reassociated and fused (they
#: vectorise); no assumption that values are finite.
_FASTMATH = {"reassoc", "contract"}


def _jit(func):
    """``numba.njit`` with the disk cache where numba can write one (a read-only install
    without a writable cache folder compiles in memory; ``QDENSITY_NUMBA_CACHE=0``: no cache)."""
    numba = _numba()
    assert numba is not None  # callers check first
    if os.environ.get("QDENSITY_NUMBA_CACHE", "1").strip().lower() not in ("0", "false", "no",
                                                                          "off"):
        try:
            return numba.njit(cache=True, fastmath=_FASTMATH)(func)
        except RuntimeError:
            pass
    return numba.njit(fastmath=_FASTMATH)(func)


def _apply_numpy(rho: np.ndarray, sup: np.ndarray, qubits: tuple[int, ...], a: int
                 ) -> np.ndarray:
    """``rho`` (R, 2**a, 2**a) through a superoperator (4**k, 4**k), shared or per row."""
    R, k = rho.shape[0], len(qubits)
    t = rho.reshape((R,) + (2,) * (2 * a))
    rows = [1 + (a - 1 - q) for q in reversed(qubits)]  # local index: last qubit most significant
    cols = [1 + a + (a - 1 - q) for q in reversed(qubits)]
    moved = np.moveaxis(t, rows + cols, list(range(1, 2 * k + 1)))
    shape = moved.shape
    flat = moved.reshape(R, 4**k, -1)
    # einsum, not matmul: no BLAS threads on these small products
    out = np.einsum("ij,rjk->rik" if sup.ndim == 2 else "rij,rjk->rik", sup, flat)
    back = np.moveaxis(out.reshape(shape), list(range(1, 2 * k + 1)), rows + cols)
    return np.ascontiguousarray(back).reshape(R, 2**a, 2**a)


def _apply_block(rho, sup, offsets):
    """In place: every (row base, column base) block of ``rho`` through ``sup``.

    The products run on separate real and imaginary parts (compiled with reassociation
    allowed, so the 16-term sums vectorise): about twice the rate of complex accumulation.
    """
    R, D = rho.shape[0], rho.shape[1]
    L = offsets.shape[0]
    LL = L * L
    mask = 0
    for t in range(L):
        mask |= offsets[t]
    per_row = sup.shape[0] > 1
    vr = np.empty(LL)
    vi = np.empty(LL)
    for r in range(R):
        S = sup[r] if per_row else sup[0]
        Sr = np.ascontiguousarray(S.real)
        Si = np.ascontiguousarray(S.imag)
        for i0 in range(D):
            if i0 & mask:
                continue
            for j0 in range(D):
                if j0 & mask:
                    continue
                for x in range(L):
                    for y in range(L):
                        c = rho[r, i0 + offsets[x], j0 + offsets[y]]
                        vr[x * L + y] = c.real
                        vi[x * L + y] = c.imag
                for x in range(L):
                    for y in range(L):
                        row = x * L + y
                        ar = 0.0
                        ai = 0.0
                        for z in range(LL):
                            ar += Sr[row, z] * vr[z] - Si[row, z] * vi[z]
                            ai += Sr[row, z] * vi[z] + Si[row, z] * vr[z]
                        rho[r, i0 + offsets[x], j0 + offsets[y]] = complex(ar, ai)
    return rho


#: The compiled ``_apply_block``, made on first use (None until then).
_KERNEL: list = []


def apply_superop(rho: np.ndarray, sup: np.ndarray, qubits: tuple[int, ...], a: int) -> np.ndarray:
    """``rho`` (R, 2**a, 2**a) through a superoperator (4**k, 4**k), shared or per row."""
    if _numba() is None:
        return _apply_numpy(rho, sup, qubits, a)
    if not _KERNEL:
        _KERNEL.append(_jit(_apply_block))
    k = len(qubits)
    offsets = np.array([sum(((l >> b) & 1) << qubits[b] for b in range(k))
                        for l in range(2**k)], dtype=np.int64)
    sup3 = np.ascontiguousarray(sup.reshape(-1, 4**k, 4**k), dtype=complex)
    return _KERNEL[0](rho, sup3, offsets)
