"""Fused blocks and the row drivers of the adjoint engine's compiled kernels (numba).

A *block* (:func:`._kernels.fuse_blocks`) is a run of Pauli rotations and fixed Pauli strings
that together touch at most ``k`` qubits (bits ``bpos``, sorted). Every gate of the run acts
only on those bits, so the run maps each *tile*, the ``2**k x V`` amplitudes that differ only
on the block's bits and on the ``log2 V`` lowest bits, to itself. A block therefore costs one
pass over the state: a tile is loaded into a small buffer (``2**k x V`` complex numbers, a few
KiB, which stays in the first-level cache), every gate of the run is applied to it there, and it
is written back. The backward sweep of adjoint differentiation does the same with the forward
state and every ``lam_m`` at once: the derivative of rotation ``g`` is a sum over the amplitudes
of ``conj(lam) Pi P phi`` at that gate, and a sum over amplitudes is a sum over tiles of the
tile-local sums, so each rotation's sum is accumulated tile by tile while the tile's copies are
undone gate by gate, exactly as the unfused sweep does it over the whole state (Jones and Gacon,
arXiv:2009.02823, Algorithm 1). A state of ``2**n`` amplitudes costs ``2 x 16 x 2**n`` bytes of
memory traffic per block instead of per gate.

Within a tile, local index ``a`` (bit ``j`` for block bit ``bpos[j]``) and the gate's local masks
``lx, lz, lc`` give the same update as :func:`._kernels_planar.apply`:
``psi_a <- c psi_a + m (-1)^{|a & lz|} psi_{a ^ lx}`` where every control in ``lc`` is 1.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution._numba import jit
from qdensity.execution.statevector._kernels_planar import (
    _back_v,
    _diag_v,
    _insert,
    _rot_v,
    _scale_v,
    _sign,
    apply,
    dense,
    permute,
    step_back,
)

#: log2 of the contiguous amplitudes per tile row (the vectorised axis), at most.
LOG_V = 6

# Inlining: the vector loops on amplitude pairs (``_pair_*``, ``_back_*``, ``_copy``) are
# inlined into their callers by numba (``inline="always"``); the per-tile helpers that call
# them (``_local``, ``_local_back``, ``_load``, ``_store``, ``_tile_setup``) are ordinary
# calls. Inlining those too cost 10-20 CPU seconds more compiling on first use (37-53 s
# against 27-31 s for the first ``value_and_gradient``) for no measured gain in speed: at
# n = 18, batch 4, one thread, 20 interleaved calls each in one process, the two builds'
# median times were within 3% on hardware-efficient, QCNN, re-uploading and non-commuting
# circuits.


@jit(fastmath=True, inline="always")
def _pair_re(Ar, Ai, Br, Bi, c, mk, mj):
    """``(a, b) <- (c a + mk b, c b + mj a)``, ``mk, mj`` real."""
    for t in range(Ar.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        br = Br[t]
        bi = Bi[t]
        Ar[t] = c * ar + mk * br
        Ai[t] = c * ai + mk * bi
        Br[t] = c * br + mj * ar
        Bi[t] = c * bi + mj * ai


@jit(fastmath=True, inline="always")
def _pair_im(Ar, Ai, Br, Bi, c, mk, mj):
    """``(a, b) <- (c a + i mk b, c b + i mj a)``, ``mk, mj`` real."""
    for t in range(Ar.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        br = Br[t]
        bi = Bi[t]
        Ar[t] = c * ar - mk * bi
        Ai[t] = c * ai + mk * br
        Br[t] = c * br - mj * ai
        Bi[t] = c * bi + mj * ar


@jit(fastmath=True, inline="always")
def _real_scale(Ar, Ai, f):
    if f != 1.0:
        for t in range(Ar.shape[0]):
            Ar[t] *= f
            Ai[t] *= f


@jit(fastmath=True)
def _local(Tr, Ti, D, V, x, z, cm, c, mr, mi):
    """One gate on a tile ``(D, V)``: ``psi_a <- c psi_a + m s_a psi_{a ^ x}`` (controls
    ``cm``). ``m`` of a Pauli rotation or string is real or imaginary (``(-i)^{#Y}`` times
    ``-i sin`` or 1): each has its loop with half the products of a complex ``m``."""
    if x == 0:
        for a in range(D):
            if a & cm == cm:
                s = _sign(a & z)
                if mi == 0.0:
                    _real_scale(Tr[a * V:a * V + V], Ti[a * V:a * V + V], c + s * mr)
                else:
                    _scale_v(Tr[a * V:a * V + V], Ti[a * V:a * V + V], c + s * mr, s * mi)
        return
    sxz = _sign(x & z)
    hx = x & -x
    if mi == 0.0:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z) * mr
                _pair_re(Tr[a * V:a * V + V], Ti[a * V:a * V + V], Tr[j * V:j * V + V],
                         Ti[j * V:j * V + V], c, s, s * sxz)
    elif mr == 0.0:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z) * mi
                _pair_im(Tr[a * V:a * V + V], Ti[a * V:a * V + V], Tr[j * V:j * V + V],
                         Ti[j * V:j * V + V], c, s, s * sxz)
    else:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z)
                sj = s * sxz
                _rot_v(Tr[a * V:a * V + V], Ti[a * V:a * V + V], Tr[j * V:j * V + V],
                       Ti[j * V:j * V + V], c, s * mr, s * mi, sj * mr, sj * mi)


@jit(fastmath=True, inline="always")
def _back_re(Ur, Ui, Vr, Vi, Ar, Ai, Br, Bi, c, mk, mj, s, sj, phi_too):
    """:func:`._kernels_planar._back_v` for a real ``m``: the real part of the sum only (the
    derivative of a gate with real ``m`` reads nothing else)."""
    sr = 0.0
    for t in range(Ur.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        br = Br[t]
        bi = Bi[t]
        ur = Ur[t]
        ui = Ui[t]
        vr = Vr[t]
        vi = Vi[t]
        sr += s * (ur * br + ui * bi) + sj * (vr * ar + vi * ai)
        Ur[t] = c * ur + mk * vr
        Ui[t] = c * ui + mk * vi
        Vr[t] = c * vr + mj * ur
        Vi[t] = c * vi + mj * ui
        if phi_too:
            Ar[t] = c * ar + mk * br
            Ai[t] = c * ai + mk * bi
            Br[t] = c * br + mj * ar
            Bi[t] = c * bi + mj * ai
    return sr


@jit(fastmath=True, inline="always")
def _back_im(Ur, Ui, Vr, Vi, Ar, Ai, Br, Bi, c, mk, mj, s, sj, phi_too):
    """:func:`._kernels_planar._back_v` for ``m = i mk``: the imaginary part of the sum only."""
    si = 0.0
    for t in range(Ur.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        br = Br[t]
        bi = Bi[t]
        ur = Ur[t]
        ui = Ui[t]
        vr = Vr[t]
        vi = Vi[t]
        si += s * (ur * bi - ui * br) + sj * (vr * ai - vi * ar)
        Ur[t] = c * ur - mk * vi
        Ui[t] = c * ui + mk * vr
        Vr[t] = c * vr - mj * ui
        Vi[t] = c * vi + mj * ur
        if phi_too:
            Ar[t] = c * ar - mk * bi
            Ai[t] = c * ai + mk * br
            Br[t] = c * br - mj * ai
            Bi[t] = c * bi + mj * ar
    return si


@jit(fastmath=True)
def _local_back(Ur, Ui, Pr, Pi, D, V, x, z, cm, c, mr, mi, phi_too):
    """``sum_a conj(u_a) s_a p_{a ^ x}`` over the controlled positions of a tile, then the
    gate applied to ``u`` (and to ``p`` when ``phi_too``), in one loop per amplitude pair. For
    a real ``m`` only the real part of the sum is formed, for an imaginary one only the
    imaginary part: ``Im(phase acc)`` reads no other (the phase is imaginary, respectively
    real)."""
    sr = 0.0
    si = 0.0
    if x == 0:
        for a in range(D):
            if a & cm == cm:
                s = _sign(a & z)
                dr, di = _diag_v(Ur[a * V:a * V + V], Ui[a * V:a * V + V], Pr[a * V:a * V + V],
                                 Pi[a * V:a * V + V], c + s * mr, s * mi, phi_too)
                sr += s * dr
                si += s * di
        return sr, si
    sxz = _sign(x & z)
    hx = x & -x
    if mi == 0.0:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z)
                sr += _back_re(Ur[a * V:a * V + V], Ui[a * V:a * V + V], Ur[j * V:j * V + V],
                               Ui[j * V:j * V + V], Pr[a * V:a * V + V], Pi[a * V:a * V + V],
                               Pr[j * V:j * V + V], Pi[j * V:j * V + V], c, s * mr,
                               s * sxz * mr, s, s * sxz, phi_too)
    elif mr == 0.0:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z)
                si += _back_im(Ur[a * V:a * V + V], Ui[a * V:a * V + V], Ur[j * V:j * V + V],
                               Ui[j * V:j * V + V], Pr[a * V:a * V + V], Pi[a * V:a * V + V],
                               Pr[j * V:j * V + V], Pi[j * V:j * V + V], c, s * mi,
                               s * sxz * mi, s, s * sxz, phi_too)
    else:
        for a in range(D):
            if a & cm == cm and not a & hx:
                j = a ^ x
                s = _sign(a & z)
                dr, di = _back_v(Ur[a * V:a * V + V], Ui[a * V:a * V + V], Ur[j * V:j * V + V],
                                 Ui[j * V:j * V + V], Pr[a * V:a * V + V], Pi[a * V:a * V + V],
                                 Pr[j * V:j * V + V], Pi[j * V:j * V + V], c, mr, mi, s,
                                 s * sxz, phi_too)
                sr += dr
                si += di
    return sr, si


@jit()
def _tile_setup(n, bpos, k, loff):
    """``(D, V, lv, tiles)`` of a block on the sorted bits ``bpos[:k]``; fills ``loff``, the
    offset of local index ``a``."""
    lv = min(bpos[0], LOG_V)
    D = 1 << k
    for a in range(D):
        o = 0
        for j in range(k):
            if a >> j & 1:
                o |= 1 << bpos[j]
        loff[a] = o
    return D, 1 << lv, lv, 1 << (n - k - lv)


@jit(fastmath=True, inline="always")
def _copy(dst, src):
    for t in range(dst.shape[0]):
        dst[t] = src[t]


@jit(fastmath=True)
def _load(re, im, base, loff, D, V, Tr, Ti):
    """A tile into its buffers (slices: a computed index would keep the loop scalar)."""
    for a in range(D):
        o = base + loff[a]
        _copy(Tr[a * V:a * V + V], re[o:o + V])
        _copy(Ti[a * V:a * V + V], im[o:o + V])


@jit(fastmath=True)
def _store(re, im, base, loff, D, V, Tr, Ti):
    for a in range(D):
        o = base + loff[a]
        _copy(re[o:o + V], Tr[a * V:a * V + V])
        _copy(im[o:o + V], Ti[a * V:a * V + V])


@jit(fastmath=True)
def block_forward(re, im, n, bpos, k, lo, hi, kind, lx, lz, lc, phase, rot, cos, sin, Tr, Ti,
                  loff):
    """Operations ``lo .. hi - 1`` (a block on bits ``bpos[:k]``) on one row, one pass."""
    D, V, lv, tiles = _tile_setup(n, bpos, k, loff)
    m = hi - lo
    gc = np.empty(m)
    gr = np.empty(m)
    gi = np.empty(m)
    for j in range(m):
        i = lo + j
        if kind[i] == 0:
            g = rot[i]
            mm = -1j * sin[g] * phase[i]
            gc[j], gr[j], gi[j] = cos[g], mm.real, mm.imag
        else:
            gc[j], gr[j], gi[j] = 0.0, phase[i].real, phase[i].imag
    for t in range(tiles):
        base = _insert(t << lv, bpos, k)
        _load(re, im, base, loff, D, V, Tr, Ti)
        for j in range(m):
            i = lo + j
            _local(Tr, Ti, D, V, lx[i], lz[i], lc[i], gc[j], gr[j], gi[j])
        _store(re, im, base, loff, D, V, Tr, Ti)


@jit(fastmath=True)
def block_backward(pr, pi, lr, li, r, n, bpos, k, lo, hi, kind, lx, lz, lc, phase, scale, rot,
                   cos, sin, need, dtheta, Pr, Pi, Lr, Li, loff):
    """The backward sweep over operations ``hi - 1 .. lo`` (a block) on row ``r``, one pass over
    ``phi`` and every ``lam_m``: each needed rotation's ``dtheta[r, m, g]``, and every gate
    undone (``+i sin``)."""
    M = lr.shape[0]
    D, V, lv, tiles = _tile_setup(n, bpos, k, loff)
    m = hi - lo
    gc = np.empty(m)
    gr = np.empty(m)
    gi = np.empty(m)
    want = np.zeros(m, dtype=np.bool_)
    for j in range(m):
        i = lo + j
        if kind[i] == 0:
            g = rot[i]
            mm = 1j * sin[r, g] * phase[i]
            gc[j], gr[j], gi[j] = cos[r, g], mm.real, mm.imag
            want[j] = need[g]
        else:
            gc[j], gr[j], gi[j] = 0.0, phase[i].real, phase[i].imag
    accr = np.zeros((M, m))
    acci = np.zeros((M, m))
    for t in range(tiles):
        base = _insert(t << lv, bpos, k)
        _load(pr, pi, base, loff, D, V, Pr, Pi)
        for mm in range(M):
            _load(lr[mm], li[mm], base, loff, D, V, Lr[mm], Li[mm])
        for j in range(m - 1, -1, -1):
            i = lo + j
            for mm in range(M):  # the last observable's loop also undoes the gate on phi
                sr, si = _local_back(Lr[mm], Li[mm], Pr, Pi, D, V, lx[i], lz[i], lc[i], gc[j],
                                     gr[j], gi[j], mm == M - 1)
                accr[mm, j] += sr
                acci[mm, j] += si
            if M == 0:
                _local(Pr, Pi, D, V, lx[i], lz[i], lc[i], gc[j], gr[j], gi[j])
        _store(pr, pi, base, loff, D, V, Pr, Pi)
        for mm in range(M):
            _store(lr[mm], li[mm], base, loff, D, V, Lr[mm], Li[mm])
    for j in range(m):
        if want[j]:
            i = lo + j
            for mm in range(M):
                acc = accr[mm, j] + 1j * acci[mm, j]
                dtheta[r, mm, rot[i]] = 2.0 * scale[i] * (phase[i] * acc).imag


@jit(fastmath=True)
def _row_forward(re, im, n, cos, sin, kind, xmask, zmask, cmask, phase, scale, rot, pos, npos,
                 offs, mat, inv, ptab, span, head, lx, lz, lc, tile, buf):
    re[:] = 0.0
    im[:] = 0.0
    re[0] = 1.0
    br = np.empty(ptab.shape[1])
    bi = np.empty(ptab.shape[1])
    Tr = np.empty(tile << LOG_V)
    Ti = np.empty(tile << LOG_V)
    loff = np.empty(tile, dtype=np.int64)
    i = 0
    while i < kind.shape[0]:
        if kind[i] == 4:
            block_forward(re, im, n, pos[i], npos[i], i + 1, i + 1 + span[i], kind, lx, lz, lc,
                          phase, rot, cos, sin, Tr, Ti, loff)
            i += 1 + span[i]
            continue
        if kind[i] == 3:
            permute(re, im, n, ptab[rot[i]], br, bi)
        elif kind[i] == 2:
            dense(re, im, n, pos[i], npos[i], offs[i], mat[i], buf)
        elif kind[i] == 1:
            apply(re, im, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i], 0.0,
                  phase[i].real, phase[i].imag)
        else:
            g = rot[i]
            m = -1j * sin[g] * phase[i]
            apply(re, im, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i], cos[g], m.real,
                  m.imag)
        i += 1


@jit(fastmath=True, nogil=True)
def forward_rows(re, im, n, cos, sin, kind, xmask, zmask, cmask, phase, scale, rot, pos,
                 npos, offs, mat, inv, ptab, span, head, lx, lz, lc, tile):
    """``re[r] + i im[r] = U(row r)|0>`` for every row of ``re``, ``im`` (R, 2**n) with the
    angles' ``cos``, ``sin`` (R, G); the callers run blocks of rows in threads (nogil)."""
    buf = np.empty(offs.shape[1], dtype=np.complex128)
    for r in range(re.shape[0]):
        _row_forward(re[r], im[r], n, cos[r], sin[r], kind, xmask, zmask, cmask, phase, scale,
                     rot, pos, npos, offs, mat, inv, ptab, span, head, lx, lz, lc, tile, buf)


@jit(fastmath=True)
def _row_backward(pr, pi, lr, li, r, n, cos, sin, need, stop, dtheta, kind, xmask, zmask,
                  cmask, phase, scale, rot, pos, npos, offs, mat, inv, ptab, span, head, lx, lz,
                  lc, tile, buf, accr, acci):
    M = lr.shape[0]
    br = np.empty(ptab.shape[1])
    bi = np.empty(ptab.shape[1])
    Pr = np.empty(tile << LOG_V)
    Pi = np.empty(tile << LOG_V)
    Lr = np.empty((M, tile << LOG_V))
    Li = np.empty((M, tile << LOG_V))
    loff = np.empty(tile, dtype=np.int64)
    i = kind.shape[0] - 1
    while i >= stop:
        h = head[i]
        if h >= 0:  # the last operation of a block: the whole block, then before its header
            block_backward(pr, pi, lr, li, r, n, pos[h], npos[h], h + 1, i + 1, kind, lx, lz,
                           lc, phase, scale, rot, cos, sin, need, dtheta, Pr, Pi, Lr, Li, loff)
            i = h - 1
            continue
        if kind[i] == 3:  # undo a permutation (its inverse's row follows it)
            permute(pr, pi, n, ptab[rot[i] + 1], br, bi)
            for mm in range(M):
                permute(lr[mm], li[mm], n, ptab[rot[i] + 1], br, bi)
        elif kind[i] == 2:
            dense(pr, pi, n, pos[i], npos[i], offs[i], inv[i], buf)
            for mm in range(M):
                dense(lr[mm], li[mm], n, pos[i], npos[i], offs[i], inv[i], buf)
        else:  # a Pauli rotation (0) or a fixed Pauli string (1: c = 0, m = its phase)
            # one call site for both: a literal False here compiled step_back twice
            c, m, want, g = 0.0, phase[i], False, rot[i]
            if kind[i] == 0:
                accr[:] = 0.0
                acci[:] = 0.0
                c, m, want = cos[r, g], 1j * sin[r, g] * phase[i], need[g]
            step_back(pr, pi, lr, li, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i], c,
                      m.real, m.imag, want, accr, acci)
            if want:
                for mm in range(M):
                    acc = accr[mm] + 1j * acci[mm]
                    dtheta[r, mm, g] = 2.0 * scale[i] * (phase[i] * acc).imag
        i -= 1


@jit(fastmath=True, nogil=True)
def backward_rows(pr, pi, lr, li, n, cos, sin, need, stop, dtheta, kind, xmask, zmask, cmask,
                  phase, scale, rot, pos, npos, offs, mat, inv, ptab, span, head, lx, lz, lc,
                  tile):
    """The backward sweep of every row of ``pr``, ``pi`` (R, 2**n) and ``lr``, ``li``
    (R, M, 2**n), filling ``dtheta`` (R, M, G) (see :func:`._kernels.backward`); the callers
    run blocks of rows in threads (nogil)."""
    buf = np.empty(offs.shape[1], dtype=np.complex128)
    accr = np.zeros(lr.shape[1])
    acci = np.zeros(lr.shape[1])
    for r in range(pr.shape[0]):
        _row_backward(pr[r], pi[r], lr[r], li[r], r, n, cos, sin, need, stop, dtheta, kind,
                      xmask, zmask, cmask, phase, scale, rot, pos, npos, offs, mat, inv, ptab,
                      span, head, lx, lz, lc, tile, buf, accr, acci)
