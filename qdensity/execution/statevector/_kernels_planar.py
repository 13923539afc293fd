"""The compiled loops of :mod:`qdensity.execution.statevector._kernels` on a planar state.

A state is two float64 arrays, real parts and imaginary parts (a batch: ``(R, 2**n)`` each).
numba's complex arithmetic does not vectorise, and neither does an interleaved float view
(stride-2 access); contiguous blocks of separate real and imaginary parts do, about 4x faster
per gate on AVX2/AVX-512. Every Pauli operation's pair partner is its lowest X (else Z) bit
(see :class:`._kernels.Tables`), so no X bit lies below the block of ``low``
contiguous amplitudes and the partner block is contiguous too; each block has one sign unless a
Z bit outside X lies below it (``rzx``-like strings, taken one amplitude at a time).
"""

from __future__ import annotations

from qdensity.execution._numba import jit

#: Blocks shorter than this go by index (a slice costs more than it saves there).
VEC = 8


@jit(inline="always")
def _insert(t, pos, npos):
    for i in range(npos):
        p = pos[i]
        t = ((t >> p) << (p + 1)) | (t & ((1 << p) - 1))
    return t


@jit(inline="always")
def _sign(v):
    v ^= v >> 32
    v ^= v >> 16
    v ^= v >> 8
    v ^= v >> 4
    v ^= v >> 2
    v ^= v >> 1
    return 1.0 - 2.0 * (v & 1)


@jit(inline="always")
def _blocks(n, pos, npos):
    """Positions with zeros at the sorted ``pos`` as ``outer`` blocks of ``low`` contiguous
    amplitudes; block starts enumerate the submasks of ``free`` in order."""
    p0 = pos[0] if npos > 0 else n
    low = 1 << p0
    skip = 0
    for i in range(npos):
        skip |= 1 << pos[i]
    free = ((1 << n) - 1) & ~skip & ~(low - 1)
    return low, free, (1 << (n - npos)) >> p0


@jit(fastmath=True, inline="always")
def _scale(re, im, s, e, fr, fi):
    """``psi[s:e] *= fr + i fi``."""
    if e - s >= VEC:
        _scale_v(re[s:e], im[s:e], fr, fi)
        return
    for t in range(s, e):
        r = re[t]
        i = im[t]
        re[t] = fr * r - fi * i
        im[t] = fr * i + fi * r


@jit(fastmath=True, inline="always")
def _scale_v(re, im, fr, fi):
    for t in range(re.shape[0]):
        r = re[t]
        i = im[t]
        re[t] = fr * r - fi * i
        im[t] = fr * i + fi * r


@jit(fastmath=True, inline="always")
def _rot(re, im, s, j, low, c, mkr, mki, mjr, mji):
    """``(a, b) <- (c a + mk b, c b + mj a)`` for ``a = psi[s + t]``, ``b = psi[j + t]``.
    (Slices, so that the loop over separate blocks vectorises; short blocks go by index.)"""
    if low < VEC:
        for t in range(low):
            ar = re[s + t]
            ai = im[s + t]
            br = re[j + t]
            bi = im[j + t]
            re[s + t] = c * ar + mkr * br - mki * bi
            im[s + t] = c * ai + mkr * bi + mki * br
            re[j + t] = c * br + mjr * ar - mji * ai
            im[j + t] = c * bi + mjr * ai + mji * ar
        return
    _rot_v(re[s:s + low], im[s:s + low], re[j:j + low], im[j:j + low], c, mkr, mki, mjr, mji)


@jit(fastmath=True, inline="always")
def _rot_v(Ar, Ai, Br, Bi, c, mkr, mki, mjr, mji):
    for t in range(Ar.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        br = Br[t]
        bi = Bi[t]
        Ar[t] = c * ar + mkr * br - mki * bi
        Ai[t] = c * ai + mkr * bi + mki * br
        Br[t] = c * br + mjr * ar - mji * ai
        Bi[t] = c * bi + mjr * ai + mji * ar


@jit(fastmath=True)
def apply(re, im, n, x, z, cm, pos, npos, c, mr, mi):
    """``psi_k <- c psi_k + m s_k psi_{k^x}`` on the controlled positions, ``m = mr + i mi``
    and ``s_k = (-1)^{|k & z|}`` (in place)."""
    low, free, outer = _blocks(n, pos, npos)
    k = 0
    if x == 0 and z == 0:  # a phase on the controlled positions
        for _ in range(outer):
            b = k | cm
            _scale(re, im, b, b + low, c + mr, mi)
            k = (k - free) & free
        return
    if x == 0:  # diagonal: blocks b and b | h (h the lowest Z bit) have opposite signs
        h = z & -z
        for _ in range(outer):
            b = k | cm
            s = _sign(b & z)
            _scale(re, im, b, b + low, c + s * mr, s * mi)
            _scale(re, im, b | h, (b | h) + low, c - s * mr, -s * mi)
            k = (k - free) & free
        return
    sxz = _sign(x & z)
    lowz = z & (low - 1)  # Z bits below the block (rzx-like strings): a sign per amplitude
    for _ in range(outer):
        b = k | cm
        s = _sign(b & z)
        sj = s * sxz
        if lowz == 0:
            _rot(re, im, b, b ^ x, low, c, s * mr, s * mi, sj * mr, sj * mi)
        else:
            for t in range(low):
                st = s * _sign(t & lowz)
                sjt = st * sxz
                _rot(re, im, b + t, (b ^ x) + t, 1, c, st * mr, st * mi, sjt * mr, sjt * mi)
        k = (k - free) & free


@jit(fastmath=True)
def dense(re, im, n, pos, npos, offs, mat, buf):
    """A fixed gate's matrix on the ``2**npos`` amplitudes at ``base + offs``."""
    d = 1 << npos
    for t in range(1 << (n - npos)):
        base = _insert(t, pos, npos)
        for a in range(d):
            buf[a] = re[base + offs[a]] + 1j * im[base + offs[a]]
        for a in range(d):
            s = 0j
            for b in range(d):
                s += mat[a, b] * buf[b]
            re[base + offs[a]] = s.real
            im[base + offs[a]] = s.imag


@jit(fastmath=True)
def permute(re, im, n, row, br, bi):
    """A permutation of the bits (:func:`._layout.tile`) in place, one tile at
    a time through the small buffers ``br``, ``bi``: ``row`` holds the mask of the bits that
    stay, the tile size ``D``, the entries' offsets and the entries they take their values
    from. (About one short-block gate's time: 1.2-1.5 ns per amplitude at n = 16.)"""
    free = row[0]
    D = row[1]
    offs = row[2:2 + D]
    src = row[2 + D:2 + 2 * D]
    k = 0
    for _ in range((1 << n) // D):
        for e in range(D):
            a = k + offs[e]
            br[e] = re[a]
            bi[e] = im[a]
        for e in range(D):
            a = k + offs[e]
            s = src[e]
            re[a] = br[s]
            im[a] = bi[s]
        k = (k - free) & free


@jit(fastmath=True, inline="always")
def _back_v(Ur, Ui, Vr, Vi, Ar, Ai, Br, Bi, c, mr, mi, s, sj, phi_too):
    """One block pair of the backward sweep in one loop: returns
    ``sum_t s conj(u_t) b_t + sj conj(v_t) a_t`` (lam = (u, v), phi = (a, b) as they come) and
    applies ``c + m s P`` to lam (and to phi when ``phi_too``)."""
    sr = 0.0
    si = 0.0
    mkr = s * mr
    mki = s * mi
    mjr = sj * mr
    mji = sj * mi
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
        si += s * (ur * bi - ui * br) + sj * (vr * ai - vi * ar)
        Ur[t] = c * ur + mkr * vr - mki * vi
        Ui[t] = c * ui + mkr * vi + mki * vr
        Vr[t] = c * vr + mjr * ur - mji * ui
        Vi[t] = c * vi + mjr * ui + mji * ur
        if phi_too:
            Ar[t] = c * ar + mkr * br - mki * bi
            Ai[t] = c * ai + mkr * bi + mki * br
            Br[t] = c * br + mjr * ar - mji * ai
            Bi[t] = c * bi + mjr * ai + mji * ar
    return sr, si


@jit(fastmath=True, inline="always")
def _diag_v(Ur, Ui, Ar, Ai, fr, fi, phi_too):
    """``sum_t conj(u_t) a_t`` as they come, then ``u *= f`` (and ``a *= f`` when ``phi_too``),
    ``f = fr + i fi``, in one loop."""
    sr = 0.0
    si = 0.0
    for t in range(Ur.shape[0]):
        ar = Ar[t]
        ai = Ai[t]
        ur = Ur[t]
        ui = Ui[t]
        sr += ur * ar + ui * ai
        si += ur * ai - ui * ar
        Ur[t] = fr * ur - fi * ui
        Ui[t] = fr * ui + fi * ur
        if phi_too:
            Ar[t] = fr * ar - fi * ai
            Ai[t] = fr * ai + fi * ar
    return sr, si


@jit(fastmath=True)
def _step_back_pairs(pr, pi, lr, li, x, z, cm, low, free, outer, sxz, c, mr, mi, want, accr,
                     acci):
    M = lr.shape[0]
    k = 0
    for mm in range(M):
        sr = 0.0
        si = 0.0
        k = 0
        for _ in range(outer):
            for t in range(low):
                b = (k | cm) + t
                j = b ^ x
                s = _sign(b & z)
                sj = s * sxz
                ar = pr[b]
                ai = pi[b]
                br = pr[j]
                bi = pi[j]
                ur = lr[mm, b]
                ui = li[mm, b]
                vr = lr[mm, j]
                vi = li[mm, j]
                if want:
                    sr += s * (ur * br + ui * bi) + sj * (vr * ar + vi * ai)
                    si += s * (ur * bi - ui * br) + sj * (vr * ai - vi * ar)
                lr[mm, b] = c * ur + s * (mr * vr - mi * vi)
                li[mm, b] = c * ui + s * (mr * vi + mi * vr)
                lr[mm, j] = c * vr + sj * (mr * ur - mi * ui)
                li[mm, j] = c * vi + sj * (mr * ui + mi * ur)
            k = (k - free) & free
        accr[mm] += sr
        acci[mm] += si
    k = 0
    for _ in range(outer):
        for t in range(low):
            b = (k | cm) + t
            j = b ^ x
            s = _sign(b & z)
            sj = s * sxz
            ar = pr[b]
            ai = pi[b]
            br = pr[j]
            bi = pi[j]
            pr[b] = c * ar + s * (mr * br - mi * bi)
            pi[b] = c * ai + s * (mr * bi + mi * br)
            pr[j] = c * br + sj * (mr * ar - mi * ai)
            pi[j] = c * bi + sj * (mr * ai + mi * ar)
        k = (k - free) & free


@jit(fastmath=True)
def _step_back_diag(pr, pi, lr, li, z, h, cm, low, free, outer, c, mr, mi, want, accr, acci):
    """Short blocks of a diagonal string (or a phase, ``h = 0``): one amplitude at a time."""
    M = lr.shape[0]
    for mm in range(M + 1):  # the observables, then phi
        sr = 0.0
        si = 0.0
        k = 0
        for _ in range(outer):
            b0 = k | cm
            s0 = _sign(b0 & z)
            for half in range(2 if h else 1):
                s = -s0 if half else s0
                fr = c + s * mr
                fi = s * mi
                for t in range(low):
                    b = (b0 | h if half else b0) + t
                    if mm < M:
                        ur = lr[mm, b]
                        ui = li[mm, b]
                        if want:
                            sr += s * (ur * pr[b] + ui * pi[b])
                            si += s * (ur * pi[b] - ui * pr[b])
                        lr[mm, b] = fr * ur - fi * ui
                        li[mm, b] = fr * ui + fi * ur
                    else:
                        ar = pr[b]
                        ai = pi[b]
                        pr[b] = fr * ar - fi * ai
                        pi[b] = fr * ai + fi * ar
            k = (k - free) & free
        if mm < M:
            accr[mm] += sr
            acci[mm] += si


@jit(fastmath=True)
def step_back(pr, pi, lr, li, n, x, z, cm, pos, npos, c, mr, mi, want, accr, acci):
    """Accumulate ``sum_k conj(lam_k) s_k phi_{k^x}`` over the controlled positions per
    observable into ``acc`` (when ``want``), then apply ``c + m s P`` to ``phi`` and every
    ``lam`` (in place; ``lr``, ``li`` are (M, 2**n))."""
    low, free, outer = _blocks(n, pos, npos)
    M = lr.shape[0]
    k = 0
    if x == 0:
        h = z & -z  # 0 for a phase: then the second block is skipped
        if low < VEC:
            _step_back_diag(pr, pi, lr, li, z, h, cm, low, free, outer, c, mr, mi, want, accr,
                            acci)
            return
        for _ in range(outer):
            b = k | cm
            s = _sign(b & z)
            for half in range(2 if h else 1):
                e = b | h if half else b
                sh = -s if half else s
                for mm in range(M):  # one pass per observable; the last one also scales phi
                    dr, di = _diag_v(lr[mm, e:e + low], li[mm, e:e + low], pr[e:e + low],
                                     pi[e:e + low], c + sh * mr, sh * mi, mm == M - 1)
                    if want:
                        accr[mm] += sh * dr
                        acci[mm] += sh * di
            k = (k - free) & free
        return
    sxz = _sign(x & z)
    lowz = z & (low - 1)  # Z bits below the block (rzx-like strings): one amplitude at a time
    step = low if lowz == 0 else 1
    if step < VEC:  # short blocks: one pair at a time, the observables' sums in registers
        _step_back_pairs(pr, pi, lr, li, x, z, cm, low, free, outer, sxz, c, mr, mi, want,
                         accr, acci)
        return
    for _ in range(outer):
        for t in range(0, low, step):
            b = (k | cm) + t
            j = b ^ x
            s = _sign(b & z)
            sj = s * sxz
            for mm in range(M):  # one pass per observable; the last one also moves phi
                dr, di = _back_v(lr[mm, b:b + step], li[mm, b:b + step], lr[mm, j:j + step],
                                 li[mm, j:j + step], pr[b:b + step], pi[b:b + step],
                                 pr[j:j + step], pi[j:j + step], c, mr, mi, s, sj,
                                 mm == M - 1)
                if want:
                    accr[mm] += dr
                    acci[mm] += di
        k = (k - free) & free
