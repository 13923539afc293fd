"""Compiled kernels of the unary engine (numba): whole circuits in one call.

The Givens rotations of a :class:`~qdensity.execution.unary.UnaryCircuit` are applied gate by
gate, in circuit order, to the rows of a work array ``Z`` (n, b) in place: ``Z[i], Z[j] <- c
Z[i] - s Z[j], s Z[i] + c Z[j]`` (the paper's RBS on unary amplitudes, Supp. D eq. 8). A row
is a contiguous run of ``b`` batch columns, so each gate is one vectorised loop over the
columns, with no per-layer gathers, scatters or sparse-matrix bookkeeping, and no Python
between the gates: one call runs a whole circuit on a block of columns.

* :func:`forward_block`: inputs ``X`` (B, n) rows ``[lo, hi)`` in, outputs out, the
  transposes to and from the work layout done inside the call.
* :func:`vjp_block`: forward pass and reverse pass of the same columns in one call. The
  reverse pass walks the gates backwards; for gate ``g`` on ``(i, j)`` with outputs ``u`` and
  output gradients ``d`` it adds ``coefficient[g] * (d_j . u_i - d_i . u_j)`` to its parameter
  (``dL/dtheta``, :func:`qdensity.execution.unary.vjp`), then rotates ``u`` and ``d`` back by
  ``-theta`` (orthogonal: the activations are recovered, none is stored).

Column blocks are independent, so the callers run blocks in threads (the kernels release the
GIL); every column goes through the same arithmetic whatever the blocks, so outputs and
``dL/dX`` are bit-for-bit those of one block (a summed parameter gradient adds the blocks'
partial sums, so it may differ in the last bits). The work array of a block (``n x b``
numbers, twice that in the reverse pass; ``b <= 64``) stays in the core's L2 cache up to
``n`` of a few thousand, and the callers pass the gates in a cache-tiled order
(:mod:`._tiles`) that keeps the rows in use in L1. Each rotation is a multiply and a fused
multiply-add per output, vectorised at LLVM's preferred width for the CPU. A gate's dot product
over the columns is added in one written order (``_lane_sum``), not left to the compiler
to reassociate: a reassociated sum was vectorised differently in a kernel compiled in the
process (its helpers inlined) and in one loaded from numba's disk cache (helpers linked as
machine code), so the gradient's last bits depended on which one ran. Without numba (or
with ``QDENSITY_NUMBA=0``) the engine keeps its numpy/scipy layer kernels
(:mod:`qdensity.execution.unary._plan`), which give the same numbers to rounding.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution import _numba

__all__ = ["available", "givens", "forward_block", "vjp_block", "forward_values", "vjp_values"]

# sin / cos of the gate angles (FreeBSD msun's argument reduction by pi/2 in three parts and
# its sin / cos kernels on [-pi/4, pi/4], branch-free so the loop vectorises; multiply-adds
# fused, which shortens the polynomials' dependency chains: 1.5x): within 1 ulp of libm, about
# 14x faster than numpy's ufuncs. |angle| >= _TRIG_LIMIT goes to libm, in a second pass run
# only when the first found such an angle.
_INVPIO2 = 6.36619772367581382433e-01
_P1, _P1T = 1.57079632673412561417e+00, 6.07710050650619224932e-11
_P2, _P2T = 6.07710050630396597660e-11, 2.02226624879595063154e-21
_P3, _P3T = 2.02226624871116645580e-21, 8.47842766036889956997e-32
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_TRIG_LIMIT = 1.0e5


def available() -> bool:
    """True when the compiled kernels run (see :func:`qdensity.execution._numba.available`)."""
    return _numba.available()


if _numba.available():
    jit = _numba.jit

    # The rotations: c a - s d as one multiply and one fused multiply-add ("contract"), on
    # rows that start on 64-byte boundaries (_work). The usual
    # block widths (64 columns; 32 in two threads) get loops of a literal length (inlined
    # where called), unrolled into whole vectors: 1.1-1.2x on rows in L1.
    @jit(nogil=True, fastmath={"contract"}, inline="always")
    def _rotations(Z, first, second, cos, sin, B):
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

    @jit(nogil=True, fastmath={"contract"})
    def _shared(Z, first, second, cos, sin):
        B = Z.shape[1]
        if B == 64:
            _rotations(Z, first, second, cos, sin, 64)
        elif B == 32:
            _rotations(Z, first, second, cos, sin, 32)
        else:
            _rotations(Z, first, second, cos, sin, B)

    @jit(nogil=True, fastmath={"contract"})
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

    @jit(nogil=True)
    def _work(n, m):  # an empty (n, m) array whose data starts on a 64-byte boundary
        buf = np.empty(n * m + 8)
        skip = (-(buf.ctypes.data // 8)) % 8
        return buf[skip:skip + n * m].reshape((n, m))

    @jit(nogil=True)
    def _load(Z, X, lo, hi):  # Z (n, hi - lo) = X[lo:hi].T
        n = Z.shape[0]
        for b in range(hi - lo):
            for k in range(n):
                Z[k, b] = X[lo + b, k]

    @jit(nogil=True)
    def _store(out, Z, lo, hi):  # out[lo:hi] = Z.T
        n = Z.shape[0]
        for b in range(hi - lo):
            for k in range(n):
                out[lo + b, k] = Z[k, b]

    @jit(nogil=True, fastmath={"contract"})
    def _forward_shared(X, lo, hi, first, second, cos, sin, out):  # cos, sin (G,)
        Z = _work(X.shape[1], hi - lo)
        _load(Z, X, lo, hi)
        _shared(Z, first, second, cos, sin)
        _store(out, Z, lo, hi)

    @jit(nogil=True, fastmath={"contract"})
    def _forward_cols(X, lo, hi, first, second, cos, sin, out):  # cos, sin (G, B)
        Z = _work(X.shape[1], hi - lo)
        _load(Z, X, lo, hi)
        _per_column(Z, first, second, cos[:, lo:hi], sin[:, lo:hi])
        _store(out, Z, lo, hi)

    @jit(nogil=True, fastmath={"contract"})
    def _sincos(a, cos, sin):  # cos, sin (same size as a, flat) of the angles a
        large = False
        for k in range(a.shape[0]):
            x = a[k]
            large |= not abs(x) < _TRIG_LIMIT
            fn = np.rint(x * _INVPIO2)  # x = fn pi/2 + (y0 + y1), |y0| <= pi/4
            r = x - fn * _P1
            w = fn * _P1T
            t = r
            w = fn * _P2
            r = t - w
            w = fn * _P2T - ((t - r) - w)
            t = r
            w = fn * _P3
            r = t - w
            w = fn * _P3T - ((t - r) - w)
            y0 = r - w
            y1 = (r - y0) - w
            z = y0 * y0
            v = z * y0
            rs = _S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))
            sy = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * _S1)
            rc = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
            hz = 0.5 * z
            ww = 1.0 - hz
            cy = ww + (((1.0 - ww) - hz) + (z * rc - y0 * y1))
            q = np.int64(fn)  # quadrant: (cos, sin) = (cy, sy), (-sy, cy), (-cy, -sy), (sy, -cy)
            odd = (q & 1) == 1
            cc = sy if odd else cy
            ss = cy if odd else sy
            cos[k] = -cc if ((q + 1) & 2) != 0 else cc
            sin[k] = -ss if (q & 2) != 0 else ss
        if not large:
            return
        for k in range(a.shape[0]):
            if not abs(a[k]) < _TRIG_LIMIT:
                cos[k] = np.cos(a[k])
                sin[k] = np.sin(a[k])

    @jit(nogil=True)
    def _trig_slice(values, pidx, coef, offset, lo, hi, cos, sin):  # gates [lo, hi) of them
        a = offset[lo:hi].copy()
        for g in range(lo, hi):
            if pidx[g] >= 0:
                a[g - lo] += coef[g] * values[pidx[g]]
        _sincos(a, cos[lo:hi], sin[lo:hi])

    @jit(nogil=True)
    def _trig_values(values, pidx, coef, offset):  # (G,) cosines and sines of shared angles
        G = pidx.shape[0]
        cos = np.empty(G)
        sin = np.empty(G)
        # np.int64(0), not 0: a literal argument compiles a second specialization of the callee
        _trig_slice(values, pidx, coef, offset, np.int64(0), G, cos, sin)
        return cos, sin

    @jit(nogil=True)
    def _forward_values(X, values, first, second, pidx, coef, offset, out):
        cos, sin = _trig_values(values, pidx, coef, offset)
        _forward_shared(X, np.int64(0), X.shape[0], first, second, cos, sin, out)

    @jit(nogil=True, inline="always")
    def _lane_sum(v, m):
        # v[0:m] summed in one fixed order, however the code around it is vectorised or
        # inlined (see the module docstring): eight running sums (columns b mod 8), added
        # pairwise, then the tail. No fast-math flags.
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
        full = m - m % 8
        for b in range(0, full, 8):
            s0 += v[b]
            s1 += v[b + 1]
            s2 += v[b + 2]
            s3 += v[b + 3]
            s4 += v[b + 4]
            s5 += v[b + 5]
            s6 += v[b + 6]
            s7 += v[b + 7]
        total = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))
        for b in range(full, m):
            total += v[b]
        return total

    @jit(nogil=True, fastmath={"contract"}, inline="always")
    def _reverse_sum(U, D, first, second, pidx, coef, cos, sin, grad, m, dots):
        # the reverse pass of the summed gradient on m columns (see _vjp_block)
        for g in range(first.shape[0] - 1, -1, -1):
            ui, uj = U[first[g]], U[second[g]]
            gi, gj = D[first[g]], D[second[g]]
            c, s = cos[g], sin[g]
            for b in range(m):
                x, y, r, t = ui[b], uj[b], gi[b], gj[b]
                dots[b] = t * x - r * y
                ui[b] = c * x + s * y
                uj[b] = c * y - s * x
                gi[b] = c * r + s * t
                gj[b] = c * t - s * r
            p = pidx[g]
            if p >= 0:
                grad[p, 0] += coef[g] * _lane_sum(dots, m)

    @jit(nogil=True, fastmath={"contract"})
    def _vjp_sum(X, GY, from_outputs, lo, hi, first, second, pidx, coef, cos, sin, grad,
                 grad_X):
        # _vjp_block for shared angles and a summed gradient (training's case) on its own:
        # inside the general kernel, its flags' branches made this loop 2x slower
        n, m = X.shape[1], hi - lo
        U = _work(n, m)
        D = _work(n, m)
        _load(U, X, lo, hi)
        _load(D, GY, lo, hi)
        if not from_outputs:
            _shared(U, first, second, cos, sin)
        _reverse_sum(U, D, first, second, pidx, coef, cos, sin, grad, m, np.empty(m))
        _store(grad_X, D, lo, hi)

    # The reverse pass, gate by gate backwards, on its rows u_i, u_j (activations) and g_i,
    # g_j (gradients), in one sweep over the columns: the gate's dot g_j u_i - g_i u_j,
    # per column into ``dots`` (then summed by _lane_sum) or into ``row``, then both pairs
    # rotated back. The loops are written out here (not called): as separate functions they ran 2x
    # slower.
    @jit(nogil=True, fastmath={"contract"})
    def _vjp_block(X, GY, from_outputs, lo, hi, first, second, pidx, coef, cos, sin,
                   per_column, per_example, grad, grad_X):
        n, m = X.shape[1], hi - lo
        U = _work(n, m)
        D = _work(n, m)
        _load(U, X, lo, hi)
        _load(D, GY, lo, hi)
        if not from_outputs:
            if per_column:
                _per_column(U, first, second, cos[:, lo:hi], sin[:, lo:hi])
            else:
                _shared(U, first, second, cos[:, 0], sin[:, 0])
        scratch = np.zeros(m)  # the dots of a fixed gate (per example), discarded
        dots = np.empty(m)  # a gate's dots, one per column, before they are summed
        for g in range(first.shape[0] - 1, -1, -1):
            ui, uj = U[first[g]], U[second[g]]
            gi, gj = D[first[g]], D[second[g]]
            p = pidx[g]
            a = coef[g]
            if per_example:  # grad (P, B): columns [lo, hi) are this block's
                row = grad[p, lo:hi] if p >= 0 else scratch
                if per_column:
                    cb, sb = cos[g, lo:hi], sin[g, lo:hi]
                    for b in range(ui.shape[0]):
                        x, y, r, t = ui[b], uj[b], gi[b], gj[b]
                        row[b] += a * (t * x - r * y)
                        ui[b] = cb[b] * x + sb[b] * y
                        uj[b] = cb[b] * y - sb[b] * x
                        gi[b] = cb[b] * r + sb[b] * t
                        gj[b] = cb[b] * t - sb[b] * r
                else:
                    c, s = cos[g, 0], sin[g, 0]
                    for b in range(ui.shape[0]):
                        x, y, r, t = ui[b], uj[b], gi[b], gj[b]
                        row[b] += a * (t * x - r * y)
                        ui[b] = c * x + s * y
                        uj[b] = c * y - s * x
                        gi[b] = c * r + s * t
                        gj[b] = c * t - s * r
            else:  # grad (P, 1): this block's own partial sums
                if per_column:
                    cb, sb = cos[g, lo:hi], sin[g, lo:hi]
                    for b in range(ui.shape[0]):
                        x, y, r, t = ui[b], uj[b], gi[b], gj[b]
                        dots[b] = t * x - r * y
                        ui[b] = cb[b] * x + sb[b] * y
                        uj[b] = cb[b] * y - sb[b] * x
                        gi[b] = cb[b] * r + sb[b] * t
                        gj[b] = cb[b] * t - sb[b] * r
                else:
                    c, s = cos[g, 0], sin[g, 0]
                    for b in range(ui.shape[0]):
                        x, y, r, t = ui[b], uj[b], gi[b], gj[b]
                        dots[b] = t * x - r * y
                        ui[b] = c * x + s * y
                        uj[b] = c * y - s * x
                        gi[b] = c * r + s * t
                        gj[b] = c * t - s * r
                if p >= 0:
                    grad[p, 0] += a * _lane_sum(dots, m)
        _store(grad_X, D, lo, hi)

    @jit(nogil=True)
    def _vjp_values(X, GY, from_outputs, values, first, second, pidx, coef, offset, grad,
                    grad_X):
        cos, sin = _trig_values(values, pidx, coef, offset)
        _vjp_sum(X, GY, from_outputs, np.int64(0), X.shape[0], first, second, pidx, coef, cos,
                 sin, grad, grad_X)


def givens(Z: np.ndarray, compiled, angles: np.ndarray) -> np.ndarray:
    """``O(angles) @ Z`` in place on ``Z`` (n, B), C-contiguous float64, and returned.

    Parameters
    ----------
    Z : numpy.ndarray, shape (n, B)
    compiled : UnaryCircuit
    angles : numpy.ndarray, shape (G,) shared by the columns, or (G, B) one per column
    """
    run = _shared if angles.ndim == 1 else _per_column
    cos, sin = np.cos(angles), np.sin(angles)
    run(Z, compiled._gate_rows[0], compiled._gate_rows[1], cos, sin)
    return Z


def _trig(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Cosines and sines, (G,) for shared angles or (G, B) for per-column ones; whether
    per-column."""
    a = np.ascontiguousarray(angles, dtype=float)
    cos, sin = np.empty(a.shape), np.empty(a.shape)
    _sincos(a.reshape(-1), cos.reshape(-1), sin.reshape(-1))
    return cos, sin, angles.ndim == 2


def trig_of(compiled, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`_trig` of ``compiled.angles(values)``; for values (P,) shared by the columns,
    the angles and their cosines and sines in one compiled pass (no (G,) temporaries).

    Parameters
    ----------
    compiled : UnaryCircuit
    values : numpy.ndarray, shape (P,) or (B, P)
    """
    if values.ndim == 2:
        return _trig(compiled.angles(values))
    G = compiled.num_gates
    cos, sin = np.empty(G), np.empty(G)
    trig_slice(compiled, values, 0, G, cos, sin)
    return cos, sin, False


def trig_slice(compiled, values: np.ndarray, lo: int, hi: int, cos: np.ndarray,
               sin: np.ndarray) -> None:
    """Gates ``[lo, hi)`` of :func:`trig_of` for values (P,) shared by the columns, written to
    ``cos[lo:hi]``, ``sin[lo:hi]`` (each slice's numbers are those of the whole pass)."""
    (pidx, coef), offset = compiled._gate_params, compiled._gate_offset
    _trig_slice(values, pidx, coef, offset, lo, hi, cos, sin)


def sincos(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cos(angles), sin(angles))`` of a 1-d float64 array, by the compiled kernel."""
    a = np.ascontiguousarray(angles, dtype=float)
    cos, sin = np.empty(a.shape), np.empty(a.shape)
    _sincos(a, cos, sin)
    return cos, sin


def forward_block(X: np.ndarray, lo: int, hi: int, compiled, trig, out: np.ndarray) -> None:
    """``out[lo:hi] = (O @ X[lo:hi].T).T`` for inputs ``X`` (B, n) C-contiguous float64.

    Parameters
    ----------
    X, out : numpy.ndarray, shape (B, n)
    lo, hi : int
        The block of batch rows.
    compiled : UnaryCircuit
    trig : tuple
        :func:`_trig` of the gate angles.
    """
    first, second = compiled._gate_rows
    run = _forward_cols if trig[2] else _forward_shared
    run(X, lo, hi, first, second, trig[0], trig[1], out)


def vjp_block(X: np.ndarray, GY: np.ndarray, from_outputs: bool, lo: int, hi: int, compiled,
              trig, per_example: bool, grad: np.ndarray, grad_X: np.ndarray) -> None:
    """Reverse pass of the rows ``[lo, hi)`` (and their forward pass unless ``from_outputs``).

    Parameters
    ----------
    X : numpy.ndarray, shape (B, n)
        Inputs, or the outputs when ``from_outputs``.
    GY : numpy.ndarray, shape (B, n)
        ``dL/dY``.
    compiled : UnaryCircuit
    trig : tuple
        :func:`_trig` of the gate angles.
    per_example : bool
        ``grad`` is (P, B) and gets columns ``[lo, hi)``; else (P, 1) and gets this block's
        sum.
    grad : numpy.ndarray, shape (P, B) or (P, 1)
        Added to.
    grad_X : numpy.ndarray, shape (B, n)
        Rows ``[lo, hi)`` set to ``dL/dX``.
    """
    first, second = compiled._gate_rows
    pidx, coef = compiled._gate_params
    if not trig[2] and not per_example:
        _vjp_sum(X, GY, from_outputs, lo, hi, first, second, pidx, coef, trig[0], trig[1], grad,
                 grad_X)
        return
    cos, sin = (trig[0], trig[1]) if trig[2] else (trig[0][:, None], trig[1][:, None])
    _vjp_block(X, GY, from_outputs, lo, hi, first, second, pidx, coef, cos, sin, trig[2],
               per_example, grad, grad_X)


def forward_values(X: np.ndarray, values: np.ndarray, compiled, out: np.ndarray) -> None:
    """:func:`forward_block` of all rows for values (P,) shared by the rows, the angles and
    their cosines and sines computed in the same compiled call (small circuits: no numpy
    calls between the arguments and the kernel)."""
    first, second = compiled._gate_rows
    pidx, coef = compiled._gate_params
    _forward_values(X, values, first, second, pidx, coef, compiled._gate_offset, out)


def vjp_values(X: np.ndarray, GY: np.ndarray, from_outputs: bool, values: np.ndarray,
               compiled, grad: np.ndarray, grad_X: np.ndarray) -> None:
    """:func:`vjp_block` of all rows for values (P,) shared by the rows, summed gradient
    ``grad`` (P, 1), the angles computed in the same compiled call."""
    first, second = compiled._gate_rows
    pidx, coef = compiled._gate_params
    _vjp_values(X, GY, from_outputs, values, first, second, pidx, coef, compiled._gate_offset,
                grad, grad_X)
