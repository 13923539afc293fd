"""Compiled statevector kernels of the adjoint engine (numba, the ``fast`` extra).

A compiled :class:`~qdensity.execution._statevector.Program` becomes flat tables (one row per
operation) and two kernels run the whole circuit per parameter row, rows in parallel
(``prange``), every gate in place on the row's state:

* a (controlled) Pauli rotation ``exp(-i a c Pi P)`` or a fixed (controlled) Pauli string: one
  loop over the amplitude pairs ``(k, k ^ x)`` on the controlled positions (a diagonal string
  scales each amplitude), ``new_k = c psi_k + m f_k psi_{k ^ x}`` with ``c = cos``,
  ``m = -i sin`` (``+i sin`` to undo it; ``c = 0, m = 1`` for a fixed string) and
  ``f_k = phase (-1)^{|k & z|}``;
* a fixed gate on up to :data:`MAX_DENSE` qubits: its matrix on the ``2**k`` amplitudes that
  differ only on its qubits; consecutive fixed gates on one qubit are multiplied once at
  compile time (a fused run);
* the backward sweep of adjoint differentiation visits a rotation once: the derivative
  ``2 c Im <lam_m| Pi P |phi>`` of every observable and the undoing of the gate on ``phi`` and
  every ``lam_m`` happen in the same loop over amplitude pairs.

The pure-numpy path of :mod:`qdensity.execution._statevector` computes the same numbers; it is
used when numba is missing or ``QDENSITY_NUMBA=0`` is set (tests run both).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["available", "Tables", "tables", "forward", "backward", "MAX_DENSE"]

#: Widest fixed (dense) gate the kernels apply; a program with a wider one runs on numpy.
MAX_DENSE = 3

try:  # the ``fast`` extra
    if os.environ.get("QDENSITY_NUMBA", "1").strip() in ("0", "false", "no", "off"):
        raise ImportError("disabled by QDENSITY_NUMBA")
    import numba
    from numba import njit, prange
except ImportError:  # pragma: no cover - exercised with QDENSITY_NUMBA=0
    numba = None


def available() -> bool:
    """True when numba is installed and not disabled by ``QDENSITY_NUMBA=0``."""
    return numba is not None


class Tables:
    """A program as flat arrays for the kernels (see the module docstring).

    Attributes
    ----------
    kind : int64 (O,)
        0 rotation, 1 fixed Pauli string, 2 fixed dense gate.
    xmask, zmask, cmask : int64 (O,)
    phase : complex128 (O,)
        The string's scalar ``(-i)^{#Y}``.
    scale : float64 (O,)
        Generator coefficient ``c`` of a rotation.
    rot : int64 (O,)
        Rotation index ``g`` (-1 for fixed gates).
    pos, npos : int64 (O, W), (O,)
        Sorted bit positions skipped by the pair loop (controls and the highest X bit; a dense
        gate's qubits).
    offs : int64 (O, 2**MAX_DENSE)
        A dense gate's amplitude offsets; ``mat`` / ``inv`` complex128 (O, D, D) its matrix
        and inverse.
    """

    def __init__(self, prog):
        from qdensity.execution._statevector import Fixed, Rotation

        ops = _fuse(prog.ops)
        O = len(ops)
        D = 2**MAX_DENSE
        self.kind = np.zeros(O, dtype=np.int64)
        self.xmask = np.zeros(O, dtype=np.int64)
        self.zmask = np.zeros(O, dtype=np.int64)
        self.cmask = np.zeros(O, dtype=np.int64)
        self.phase = np.ones(O, dtype=np.complex128)
        self.scale = np.zeros(O, dtype=np.float64)
        self.rot = np.full(O, -1, dtype=np.int64)
        self.pos = np.zeros((O, max(MAX_DENSE, prog.num_qubits)), dtype=np.int64)
        self.npos = np.zeros(O, dtype=np.int64)
        self.offs = np.zeros((O, D), dtype=np.int64)
        self.mat = np.zeros((O, D, D), dtype=np.complex128)
        self.inv = np.zeros((O, D, D), dtype=np.complex128)
        self.ok = True
        g = 0
        for i, op in enumerate(ops):
            gather = op.gather if isinstance(op, Rotation) else getattr(op, "gather", None)
            if gather is not None:
                self.kind[i] = 0 if isinstance(op, Rotation) else 1
                self.xmask[i], self.zmask[i] = gather.xmask, gather.zmask
                self.cmask[i], self.phase[i] = gather.cmask, gather.scalar
                skip = [q for q in range(prog.num_qubits) if gather.cmask >> q & 1]
                if gather.xmask or gather.zmask:  # the pair partner: highest X (else Z) bit
                    skip.append(int(gather.xmask or gather.zmask).bit_length() - 1)
                skip.sort()
                self.pos[i, :len(skip)] = skip
                self.npos[i] = len(skip)
                if isinstance(op, Rotation):
                    self.scale[i], self.rot[i] = op.coefficient, g
                    g += 1
                continue
            assert isinstance(op, Fixed)
            k = len(op.qubits)
            if k > MAX_DENSE:
                self.ok = False
                continue
            self.kind[i] = 2
            self.pos[i, :k] = sorted(op.qubits)
            self.npos[i] = k
            for a in range(2**k):
                self.offs[i, a] = sum(((a >> b) & 1) << q for b, q in enumerate(op.qubits))
            self.mat[i, :2**k, :2**k] = op.matrix
            self.inv[i, :2**k, :2**k] = op.matrix.conj().T
        self.num_rotations = g
        #: position of rotation g among the operations
        self.rot_pos = np.flatnonzero(self.kind == 0)
        if len(self.rot_pos) and not np.array_equal(self.rot[self.rot_pos],
                                                    np.arange(len(self.rot_pos))):
            raise AssertionError("rotations out of order")  # pragma: no cover

    def args(self):
        return (self.kind, self.xmask, self.zmask, self.cmask, self.phase, self.scale, self.rot,
                self.pos, self.npos, self.offs, self.mat, self.inv)


def _fuse(ops: list) -> list:
    """Consecutive fixed one-qubit gates on one qubit multiplied into one (in circuit order)."""
    from qdensity.execution._statevector import Fixed

    out: list = []
    for op in ops:
        if (isinstance(op, Fixed) and op.matrix is not None and len(op.qubits) == 1 and out
                and isinstance(out[-1], Fixed) and out[-1].matrix is not None
                and out[-1].qubits == op.qubits):
            out[-1] = Fixed(op.qubits, op.matrix @ out[-1].matrix)
        else:
            out.append(op)
    return out


def tables(prog) -> Tables | None:
    """The program's kernel tables (made once, kept on the program), or None when the kernels
    cannot run it (numba missing or disabled, or a fixed gate wider than MAX_DENSE)."""
    if numba is None:
        return None
    tab = prog.__dict__.get("_tables")
    if tab is None:
        tab = Tables(prog)
        prog.__dict__["_tables"] = tab
    return tab if tab.ok else None


if numba is not None:

    @njit(cache=True, inline="always")
    def _insert(t, pos, npos):
        for i in range(npos):
            p = pos[i]
            t = ((t >> p) << (p + 1)) | (t & ((1 << p) - 1))
        return t

    @njit(cache=True, inline="always")
    def _sign(v):
        v ^= v >> 32
        v ^= v >> 16
        v ^= v >> 8
        v ^= v >> 4
        v ^= v >> 2
        v ^= v >> 1
        return 1.0 - 2.0 * (v & 1)

    @njit(cache=True, inline="always")
    def _high(z):
        """The highest set bit of ``z`` (0 for 0)."""
        while z & (z - 1):
            z &= z - 1
        return z

    @njit(cache=True, inline="always")
    def _blocks(n, pos, npos):
        """The positions with zeros at the sorted ``pos`` as ``outer`` blocks of ``low``
        contiguous amplitudes: block starts enumerate the submasks of ``free`` in order."""
        p0 = pos[0] if npos > 0 else n
        low = 1 << p0
        skip = 0
        for i in range(npos):
            skip |= 1 << pos[i]
        free = ((1 << n) - 1) & ~skip & ~(low - 1)
        return low, free, (1 << (n - npos)) >> p0

    @njit(cache=True, inline="always")
    def _pair(psi, k, x, mk, mj, c):
        j = k ^ x
        a = psi[k]
        b = psi[j]
        psi[k] = c * a + mk * b
        psi[j] = c * b + mj * a

    @njit(cache=True, fastmath=True)
    def _pauli(psi, n, x, z, cm, pos, npos, c, m):
        """``psi_k <- c psi_k + m f_k psi_{k^x}`` on the controlled positions (in place)."""
        low, free, outer = _blocks(n, pos, npos)
        lowz = z & (low - 1)
        k = 0
        if x == 0 and z == 0:  # a phase on the controlled positions
            f = c + m
            for _ in range(outer):
                base = k | cm
                for lo in range(low):
                    psi[base | lo] *= f
                k = (k - free) & free
            return
        if x == 0:  # diagonal: pairs (k, k ^ h), h the highest Z bit, have opposite signs
            h = _high(z)
            for _ in range(outer):
                base = k | cm
                sh = _sign(base & z)
                if lowz == 0:
                    f = c + m * sh
                    g = c - m * sh
                    for lo in range(low):
                        psi[base | lo] *= f
                        psi[base | lo | h] *= g
                else:
                    for lo in range(low):
                        s = sh * _sign(lo & lowz)
                        psi[base | lo] *= c + m * s
                        psi[base | lo | h] *= c - m * s
                k = (k - free) & free
            return
        sxz = _sign(x & z)
        for _ in range(outer):
            base = k | cm
            mh = m * _sign(base & z)
            if lowz == 0:  # one sign for the whole block (rx, ry, rxx, cx, ...)
                mj = mh * sxz
                for lo in range(low):
                    _pair(psi, base | lo, x, mh, mj, c)
            else:
                for lo in range(low):
                    mk = mh * _sign(lo & lowz)
                    _pair(psi, base | lo, x, mk, mk * sxz, c)
            k = (k - free) & free

    @njit(cache=True, fastmath=True)
    def _dense(psi, n, pos, npos, offs, mat, buf):
        d = 1 << npos
        for t in range(1 << (n - npos)):
            base = _insert(t, pos, npos)
            for a in range(d):
                buf[a] = psi[base + offs[a]]
            for a in range(d):
                s = 0j
                for b in range(d):
                    s += mat[a, b] * buf[b]
                psi[base + offs[a]] = s

    @njit(cache=True, fastmath=True)
    def _row_forward(psi, n, cos, sin, kind, xmask, zmask, cmask, phase, scale, rot, pos, npos,
                     offs, mat, inv, buf):
        for i in range(kind.shape[0]):
            if kind[i] == 2:
                _dense(psi, n, pos[i], npos[i], offs[i], mat[i], buf)
            elif kind[i] == 1:
                _pauli(psi, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i], 0.0,
                       phase[i] + 0j)
            else:
                g = rot[i]
                _pauli(psi, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i],
                       cos[g], -1j * sin[g] * phase[i])

    @njit(cache=True, parallel=True, fastmath=True)
    def _forward_rows(states, n, cos, sin, kind, xmask, zmask, cmask, phase, scale, rot, pos,
                      npos, offs, mat, inv):
        for r in prange(states.shape[0]):
            psi = states[r]
            psi[:] = 0.0
            psi[0] = 1.0
            buf = np.empty(offs.shape[1], dtype=np.complex128)
            _row_forward(psi, n, cos[r], sin[r], kind, xmask, zmask, cmask, phase, scale, rot,
                         pos, npos, offs, mat, inv, buf)

    @njit(cache=True, fastmath=True)
    def _forward_serial(states, n, cos, sin, kind, xmask, zmask, cmask, phase, scale, rot, pos,
                        npos, offs, mat, inv):
        buf = np.empty(offs.shape[1], dtype=np.complex128)
        for r in range(states.shape[0]):
            psi = states[r]
            psi[:] = 0.0
            psi[0] = 1.0
            _row_forward(psi, n, cos[r], sin[r], kind, xmask, zmask, cmask, phase, scale, rot,
                         pos, npos, offs, mat, inv, buf)

    @njit(cache=True, inline="always")
    def _back_pair(phi, lam, k, x, sk, sj, c, m, want, out):
        j = k ^ x
        a = phi[k]
        b = phi[j]
        mk = m * sk
        mj = m * sj
        phi[k] = c * a + mk * b
        phi[j] = c * b + mj * a
        for mm in range(lam.shape[0]):
            u = lam[mm, k]
            v = lam[mm, j]
            if want:
                out[mm] += sk * (u.conjugate() * b) + sj * (v.conjugate() * a)
            lam[mm, k] = c * u + mk * v
            lam[mm, j] = c * v + mj * u

    @njit(cache=True, inline="always")
    def _back_diag(phi, lam, k, s, c, m, want, out):
        a = phi[k]
        f = c + m * s
        phi[k] = f * a
        for mm in range(lam.shape[0]):
            b = lam[mm, k]
            if want:
                out[mm] += s * (b.conjugate() * a)
            lam[mm, k] = f * b

    @njit(cache=True, fastmath=True)
    def _step_back_one(phi, lam, x, z, cm, low, free, outer, sxz, c, m, want):
        acc = 0j
        k = 0
        for _ in range(outer):
            base = k | cm
            sk = _sign(base & z)
            sj = sk * sxz
            mk = m * sk
            mj = m * sj
            if want:
                part = 0j
                for lo in range(low):
                    kk = base | lo
                    j = kk ^ x
                    a = phi[kk]
                    b = phi[j]
                    u = lam[kk]
                    v = lam[j]
                    part += sk * (u.conjugate() * b) + sj * (v.conjugate() * a)
                    phi[kk] = c * a + mk * b
                    phi[j] = c * b + mj * a
                    lam[kk] = c * u + mk * v
                    lam[j] = c * v + mj * u
                acc += part
            else:
                for lo in range(low):
                    kk = base | lo
                    j = kk ^ x
                    a = phi[kk]
                    b = phi[j]
                    u = lam[kk]
                    v = lam[j]
                    phi[kk] = c * a + mk * b
                    phi[j] = c * b + mj * a
                    lam[kk] = c * u + mk * v
                    lam[j] = c * v + mj * u
            k = (k - free) & free
        return acc

    @njit(cache=True, fastmath=True)
    def _step_back_diag_one(phi, lam, z, cm, low, free, outer, c, m):
        """One observable, a diagonal string with no Z bit below the block: pairs
        ``(k, k ^ h)`` with opposite signs."""
        h = _high(z)
        acc = 0j
        k = 0
        for _ in range(outer):
            base = k | cm
            sk = _sign(base & z)
            f = c + m * sk
            g = c - m * sk
            part = 0j
            for lo in range(low):
                kk = base | lo
                j = kk | h
                a = phi[kk]
                b = phi[j]
                u = lam[kk]
                v = lam[j]
                part += sk * (u.conjugate() * a - v.conjugate() * b)
                phi[kk] = f * a
                phi[j] = g * b
                lam[kk] = f * u
                lam[j] = g * v
            acc += part
            k = (k - free) & free
        return acc

    @njit(cache=True, fastmath=True)
    def _step_back(phi, lam, n, x, z, cm, pos, npos, c, m, want, out):
        """Accumulate ``sum_k conj(lam_k) f_k phi_{k^x}`` per observable into ``out`` (when
        ``want``) and apply ``c + m f P`` to ``phi`` and every ``lam`` (in place)."""
        low, free, outer = _blocks(n, pos, npos)
        lowz = z & (low - 1)
        sxz = _sign(x & z)
        if lam.shape[0] == 1 and x != 0 and lowz == 0:  # one observable: scalar accumulator
            out[0] += _step_back_one(phi, lam[0], x, z, cm, low, free, outer, sxz, c, m, want)
            return
        if lam.shape[0] == 1 and x == 0 and z != 0 and lowz == 0:
            out[0] += _step_back_diag_one(phi, lam[0], z, cm, low, free, outer, c, m)
            return
        k = 0
        for _ in range(outer):
            base = k | cm
            sh = _sign(base & z)
            if x == 0:
                h = _high(z)
                for lo in range(low):
                    sk = sh * _sign(lo & lowz)
                    _back_diag(phi, lam, base | lo, sk, c, m, want, out)
                    if h:
                        _back_diag(phi, lam, base | lo | h, -sk, c, m, want, out)
            elif lowz == 0:
                sj = sh * sxz
                for lo in range(low):
                    _back_pair(phi, lam, base | lo, x, sh, sj, c, m, want, out)
            else:
                for lo in range(low):
                    sk = sh * _sign(lo & lowz)
                    _back_pair(phi, lam, base | lo, x, sk, sk * sxz, c, m, want, out)
            k = (k - free) & free

    @njit(cache=True, fastmath=True)
    def _row_backward(p, lr, r, n, cos, sin, need, stop, dtheta, kind, xmask, zmask, cmask,
                      phase, scale, rot, pos, npos, offs, mat, inv, buf, acc):
        M = lr.shape[0]
        for i in range(kind.shape[0] - 1, stop - 1, -1):
            if kind[i] == 2:
                _dense(p, n, pos[i], npos[i], offs[i], inv[i], buf)
                for mm in range(M):
                    _dense(lr[mm], n, pos[i], npos[i], offs[i], inv[i], buf)
            elif kind[i] == 1:
                _step_back(p, lr, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i], 0.0,
                           phase[i] + 0j, False, acc)
            else:
                g = rot[i]
                acc[:] = 0.0
                _step_back(p, lr, n, xmask[i], zmask[i], cmask[i], pos[i], npos[i],
                           cos[r, g], 1j * sin[r, g] * phase[i], need[g], acc)
                if need[g]:
                    for mm in range(M):
                        dtheta[r, mm, g] = 2.0 * scale[i] * (phase[i] * acc[mm]).imag

    @njit(cache=True, parallel=True, fastmath=True)
    def _backward_rows(phi, lam, n, cos, sin, need, stop, dtheta, kind, xmask, zmask, cmask,
                       phase, scale, rot, pos, npos, offs, mat, inv):
        for r in prange(phi.shape[0]):
            buf = np.empty(offs.shape[1], dtype=np.complex128)
            acc = np.zeros(lam.shape[1], dtype=np.complex128)
            _row_backward(phi[r], lam[r], r, n, cos, sin, need, stop, dtheta, kind, xmask,
                          zmask, cmask, phase, scale, rot, pos, npos, offs, mat, inv, buf, acc)

    @njit(cache=True, fastmath=True)
    def _backward_serial(phi, lam, n, cos, sin, need, stop, dtheta, kind, xmask, zmask, cmask,
                         phase, scale, rot, pos, npos, offs, mat, inv):
        buf = np.empty(offs.shape[1], dtype=np.complex128)
        acc = np.zeros(lam.shape[1], dtype=np.complex128)
        for r in range(phi.shape[0]):
            _row_backward(phi[r], lam[r], r, n, cos, sin, need, stop, dtheta, kind, xmask,
                          zmask, cmask, phase, scale, rot, pos, npos, offs, mat, inv, buf, acc)


#: Rows run in parallel threads only above this much work (amplitudes x operations, about
#: 10-20 ms on one core): below it, waking the threads costs more than it saves.
PARALLEL_WORK = 2**24
#: ... and only while the machine has an idle core (1-minute load average + 1 <= cores): on a
#: busy machine a parallel region waits for its slowest thread, and a thread that waits for a
#: core made calls 5-15x slower than one thread (measured at a load of 13 on 2 cores).
LOAD_AWARE = True


def _parallel(rows: int, n: int, ops: int) -> bool:
    if rows < 2 or numba.get_num_threads() < 2 or rows * ops * 2**n < PARALLEL_WORK:
        return False
    if LOAD_AWARE and hasattr(os, "getloadavg"):
        return os.getloadavg()[0] + 1 <= (os.cpu_count() or 1)
    return True


def forward(states, n, cos, sin, tab: Tables) -> None:
    """``states[r] = U(row r)|0>`` in place: ``states`` (R, 2**n) complex, ``cos``/``sin``
    (R, G) of ``c * angle`` per rotation; rows in parallel for large work."""
    run = _forward_rows if _parallel(states.shape[0], n, tab.kind.size) else _forward_serial
    run(states, n, cos, sin, *tab.args())


def backward(phi, lam, n, cos, sin, need, stop, dtheta, tab: Tables) -> None:
    """The backward sweep from the last operation down to operation ``stop``: ``phi``
    (R, 2**n) the forward states and ``lam`` (R, M, 2**n) the observables applied to them
    (both overwritten); fills ``dtheta`` (R, M, G), ``d f_m / d angle_g`` for ``need[g]``."""
    run = _backward_rows if _parallel(phi.shape[0], n, tab.kind.size) else _backward_serial
    run(phi, lam, n, cos, sin, need, stop, dtheta, *tab.args())
