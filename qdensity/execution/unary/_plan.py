"""Unary engine kernels for angles shared by the batch: each layer one sparse matrix product.

A layer of disjoint Givens rotations is a sparse matrix with two nonzeros per row. Its rows
(outputs) may come out in any order, so every full ("dense") layer writes its output with
the layer's pairs on adjacent rows, ``[i0, j0, i1, j1, ..., idle pairs]``; the next layer's
column indices refer to that order. One compiled call per layer then does the gather, the
rotation and the write (``scipy``'s CSR times dense kernel, ``y_r += a x_c`` on whole batch
rows), and the reverse pass reads each pair's activations and gradients as strided views.
The forward pass multiplies two consecutive dense layers at once (four nonzeros per row:
the same flops, half the calls and half the memory writes). Layers with few gates
("sparse", ``4 L < n``) rotate their rows in place instead (gather, product, scatter), so a
deep narrow circuit costs ``O(gates)``, not ``O(layers * n)``.

The structure (column indices, where each nonzero's value comes from) is built once per
circuit; a call computes the cosines and sines of all gates at once and gathers the values
of all nonzeros with one ``take``. An odd ``n`` gets one zero padding row.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from scipy.sparse import csr_matrix

from qdensity.execution._threads import blocks, num_threads, run_blocks, split
from qdensity.execution.unary import _kernels as _unary_kernels
from qdensity.execution.unary._layers import backward, rotate

try:  # the compiled loop behind ``csr_matrix @ ndarray``, called without its Python checks
    from scipy.sparse._sparsetools import csr_matvecs as _csr_matvecs
except ImportError:  # pragma: no cover - a scipy that moved it: same result, slower
    _csr_matvecs = None  # type: ignore[assignment]  # optional: checked before each use

__all__: list[str] = []

_CHUNK_BYTES = 1 << 24  # reverse pass: layer outputs kept for one batched dot product


@dataclass(frozen=True)
class Step:
    """One layer of the reverse pass (``L`` gates); nonzeros ``[offset, offset + 2 rows)``."""

    dense: bool  # out of place into the layer's pair order; else in place on ``scatter``
    rows: int  # output rows of its matrices: n_pad (dense) or 2L (sparse)
    offset: int
    scatter: np.ndarray | None  # sparse: positions of [i0, j0, i1, j1, ...] in the order
    pidx: np.ndarray  # (L,) parameter indices (-1 fixed), pair k on rows 2k, 2k + 1
    coefficient: np.ndarray  # (L,)
    trainable: np.ndarray | None  # positions of the gates with pidx >= 0 (None: all)
    unique: bool  # trainable parameter indices distinct within the layer
    dot_offset: int  # where the layer's gate dots start in the per-call dot vectors


@dataclass(frozen=True)
class Plan:
    """Sparse-matrix form of a layered circuit (see the module docstring)."""

    n: int
    n_pad: int
    steps: list[Step]  # reverse pass, one per layer
    fwd: list[tuple]  # forward pass: (rows, indptr, indices, start, stop, scatter or None)
    indptr: dict  # nnz per row -> arange(0, k n_pad + 1, k)
    fwd_cols: np.ndarray
    fwd_src: np.ndarray  # (2, nnz) factors of each value in [cos (G), sin (G), -sin (G), 1, 0]
    bwd_cols: np.ndarray
    bwd_src: np.ndarray
    final: np.ndarray  # (n_pad,) qubit at each position after the last layer
    final_pos: np.ndarray | None  # (n,) row of each qubit after the forward pass (None: q)
    dot_pidx: np.ndarray  # parameter index of each trainable gate's dot, in dot order
    dot_keep: np.ndarray  # which dots are those
    dot_coef: np.ndarray  # their coefficients
    num_dots: int  # gates
    num_dense: int  # dense layers


def _slots(n_pad, layer, dense, one, zero):
    """Pairs ``(I, J)`` of a layer (idle qubits paired after the gates when dense) and the
    value-table sources of their ``c``, ``s``, ``-s``."""
    G3 = zero - 1  # 3 G
    gates, i, j = layer.gates, layer.first, layer.second
    if dense:
        used = np.zeros(n_pad, bool)
        used[i] = used[j] = True
        idle = np.flatnonzero(~used)
        i, j = np.concatenate([i, idle[0::2]]), np.concatenate([j, idle[1::2]])
    pad = i.size - gates.size
    c = np.concatenate([gates, np.full(pad, one)])
    s = np.concatenate([G3 // 3 + gates, np.full(pad, zero)])
    ns = np.concatenate([2 * (G3 // 3) + gates, np.full(pad, zero)])
    return i, j, c, s, ns


def _alpha_beta(n_pad, I, J, c, s, ns, pos):
    """Per qubit ``x`` of a dense layer: ``y_x = alpha in[col_a] + beta in[col_b]``."""
    col_a, col_b = np.empty(n_pad, np.intp), np.empty(n_pad, np.intp)
    alpha, beta = np.empty(n_pad, np.intp), np.empty(n_pad, np.intp)
    col_a[I] = col_a[J] = pos[I]
    col_b[I] = col_b[J] = pos[J]
    alpha[I], beta[I] = c, ns  # y_i = c x_i - s x_j
    alpha[J], beta[J] = s, c  # y_j = s x_i + c x_j
    return col_a, col_b, alpha, beta


def make_plan(n: int, layers, num_gates: int) -> Plan:
    """Build the sparse structure of ``layers`` (:func:`._unary_layers.schedule`) once."""
    n_pad = n + n % 2
    one, zero = 3 * num_gates, 3 * num_gates + 1
    order, pos = np.arange(n_pad), np.arange(n_pad)  # qubit at each position and inverse
    steps, bc, bs, dots = [], [], [], 0
    fwd: list[tuple]  # (rows, k, offset, scatter or None), then the Plan's entries
    fwd, fc, fs, offset, fwd_offset = [], [], [], 0, 0
    pending = None  # a dense layer's (col_a, col_b, alpha, beta) waiting for its partner

    def emit_dense_single(cab):  # output rows in the layer's pair order X
        col_a, col_b, alpha, beta, X = cab
        nonlocal fwd_offset
        fc.append(np.stack([col_a[X], col_b[X]], 1).ravel())
        fs.append(np.stack([np.stack([alpha[X], beta[X]], 1).ravel(), np.full(2 * n_pad, one)]))
        fwd.append((n_pad, 2, fwd_offset, None))
        fwd_offset += 2 * n_pad

    for layer in layers:
        L = int(layer.gates.size)
        dense = 4 * L >= n_pad
        I, J, c, s, ns = _slots(n_pad, layer, dense, one, zero)
        K = I.size
        if dense:
            # reverse: row q (a position of the previous order) holding qubit x of pair k
            # is c y_i + s y_j (x = i_k) or -s y_i + c y_j (x = j_k), on the new rows 2k, 2k+1
            slot, role = np.empty(n_pad, np.intp), np.zeros(n_pad, bool)
            slot[I] = slot[J] = np.arange(K)
            role[J] = True
            k, r = slot[order], role[order]
            bc.append(np.stack([2 * k, 2 * k + 1], 1).ravel())
            bs.append(np.stack([np.where(r, ns[k], c[k]), np.where(r, c[k], s[k])], 1).ravel())
            X = np.stack([I, J], 1).ravel()
            cab = _alpha_beta(n_pad, I, J, c, s, ns, pos) + (X,)
            if pending is None:
                pending = cab
            else:  # fuse: y2_x = a2 y1_i + b2 y1_j, (i, j) the pair of x, y1 the previous layer
                col_a, col_b, alpha, beta, _ = pending
                a2, b2 = cab[2][X], cab[3][X]  # row x: a2 y1[i] + b2 y1[j] (i, j its pair)
                xi, xj = np.stack([I, I], 1).ravel(), np.stack([J, J], 1).ravel()
                fc.append(np.stack([col_a[xi], col_b[xi], col_a[xj], col_b[xj]], 1).ravel())
                f2 = np.stack([a2, a2, b2, b2], 1).ravel()
                f1 = np.stack([alpha[xi], beta[xi], alpha[xj], beta[xj]], 1).ravel()
                fs.append(np.stack([f2, f1]))
                fwd.append((n_pad, 4, fwd_offset, None))
                fwd_offset += 4 * n_pad
                pending = None
            order = X
            pos[order] = np.arange(n_pad)
            scatter = None
        else:  # in place: the transpose acts on the gathered rows [i0, j0, ...] (local columns)
            if pending is not None:
                emit_dense_single(pending)
                pending = None
            k = np.repeat(np.arange(K), 2)
            bc.append(np.stack([2 * k, 2 * k + 1], 1).ravel())
            bs.append(np.stack([np.stack([c, ns], 1).ravel(), np.stack([s, c], 1).ravel()],
                               1).ravel())
            pi, pj = pos[I], pos[J]
            scatter = np.stack([pi, pj], 1).ravel()
            fc.append(np.stack([pi, pj, pi, pj], 1).ravel())
            fs.append(np.stack([np.stack([c, ns, s, c], 1).ravel(), np.full(4 * K, one)]))
            fwd.append((2 * K, 2, fwd_offset, scatter))
            fwd_offset += 4 * K
        p = layer.pidx
        steps.append(Step(dense, 2 * K, offset, scatter, p, layer.coefficient, layer.trainable,
                          layer.unique, dots))
        offset += 4 * K
        dots += L
    if pending is not None:
        emit_dense_single(pending)
    pidx = np.concatenate([st.pidx for st in steps]) if steps else np.zeros(0, np.intp)
    coef = np.concatenate([st.coefficient for st in steps]) if steps else np.zeros(0)
    keep = np.flatnonzero(pidx >= 0)
    itype = np.int32 if 4 * n_pad < 2**31 else np.int64

    def cat(parts, dtype, shape=(0,)):
        return np.ascontiguousarray(np.concatenate(parts, axis=-1) if parts
                                    else np.zeros(shape), dtype)

    final_pos = pos[:n].copy()
    if fwd and fwd[-1][3] is None:  # the last product writes its rows in qubit order
        rows, width = fwd[-1][:2]
        fc[-1] = fc[-1].reshape(rows, width)[pos].ravel()
        fs[-1] = fs[-1].reshape(2, rows, width)[:, pos].reshape(2, -1)
        final_pos = None
    ptrs = {k: np.arange(0, k * n_pad + 1, k, dtype=itype) for k in (2, 4)}
    fwd_cols = cat(fc, itype)
    fwd = [(rows, ptrs[k][:rows + 1], fwd_cols[o:o + k * rows], o, o + k * rows, scatter)
           for rows, k, o, scatter in fwd]
    return Plan(n, n_pad, steps, fwd, ptrs, fwd_cols, cat(fs, np.intp, (2, 0)), cat(bc, itype),
                cat(bs, np.intp), order, final_pos, pidx[keep], keep, coef[keep], dots,
                sum(st.dense for st in steps))


def _table(angles: np.ndarray) -> np.ndarray:
    """The value table ``[cos (G), sin (G), -sin (G), 1, 0]`` of the gate angles."""
    tab = np.empty(3 * angles.size + 2)
    tab[3 * angles.size:] = (1.0, 0.0)
    _trig(tab, angles, 0, angles.size)
    return tab


def _trig(tab: np.ndarray, angles: np.ndarray, lo: int, hi: int) -> None:
    """Gates ``[lo, hi)`` of the table's cosines, sines and negated sines."""
    G = angles.size
    np.cos(angles[lo:hi], out=tab[lo:hi])
    np.sin(angles[lo:hi], out=tab[G + lo:G + hi])
    np.negative(tab[G + lo:G + hi], out=tab[2 * G + lo:2 * G + hi])


def _product(indptr, rows, cols, indices, data, X, out) -> None:
    """``out = A @ X`` for the CSR matrix ``(data, indices, indptr)`` of shape rows x cols."""
    if _csr_matvecs is None:
        out[...] = csr_matrix((data, indices, indptr), shape=(rows, cols)) @ X
        return
    out.fill(0.0)
    _csr_matvecs(rows, cols, X.shape[1], indptr, indices, data, X.reshape(-1), out.reshape(-1))


def plan_rotate(Z: np.ndarray, plan: Plan, angles: np.ndarray) -> np.ndarray:
    """``O(angles) @ Z`` for columns ``Z`` (n, B); returns a new array (``Z`` is kept).

    A wide batch runs in threads (:mod:`qdensity.execution._threads`): the cosines, sines and
    nonzeros in slices, then the layer loop on contiguous column blocks; every number goes through
    the same arithmetic as in one thread, so the results are the same bits.
    """
    ranges = blocks(Z.shape[1], plan.fwd_cols.size)
    if len(ranges) > 1:
        return _threaded(Z, plan, angles, ranges)
    tab = _table(angles)
    data = np.take(tab, plan.fwd_src[0])
    data *= np.take(tab, plan.fwd_src[1])
    return _run(Z, plan, data)


def _threaded(Z: np.ndarray, plan: Plan, angles: np.ndarray, ranges) -> np.ndarray:
    """:func:`plan_rotate` in ``len(ranges)`` threads, ``ranges`` the column blocks."""
    k, G, nnz = len(ranges), angles.size, plan.fwd_cols.size
    tab = np.empty(3 * G + 2)
    tab[3 * G:] = (1.0, 0.0)
    data = np.empty(nnz)

    def values(lo, hi):
        np.multiply(np.take(tab, plan.fwd_src[0, lo:hi]), np.take(tab, plan.fwd_src[1, lo:hi]),
                    out=data[lo:hi])

    run_blocks(lambda lo, hi: _trig(tab, angles, lo, hi), split(G, k))
    run_blocks(values, split(nnz, k))
    out = np.empty((plan.n, Z.shape[1]))

    def part(lo, hi):
        out[:, lo:hi] = _run(Z[:, lo:hi], plan, data)

    run_blocks(part, ranges)
    return out


def _run(Z: np.ndarray, plan: Plan, data: np.ndarray) -> np.ndarray:
    """The forward layer loop on the columns ``Z`` (n, B) with the nonzeros ``data``."""
    n, n_pad = plan.n, plan.n_pad
    B = Z.shape[1]
    if n == n_pad:
        cur = np.array(Z, dtype=float, order="C")
    else:
        cur = np.zeros((n_pad, B))
        cur[:n] = Z
    nxt = np.empty_like(cur)
    if _csr_matvecs is None:  # pragma: no cover - exercised by a test that hides it
        for rows, ptr, ind, o, e, scatter in plan.fwd:
            out = nxt[:rows]
            _product(ptr, rows, n_pad, ind, data[o:e], cur, out)
            if scatter is None:
                cur, nxt = nxt, cur
            else:
                cur[scatter] = out
        return _natural(cur, plan)
    cf, nf = cur.reshape(-1), nxt.reshape(-1)
    for rows, ptr, ind, o, e, scatter in plan.fwd:
        if scatter is None:  # the hot loop: one compiled call per two layers
            nf.fill(0.0)
            _csr_matvecs(n_pad, n_pad, B, ptr, ind, data[o:e], cf, nf)
            cur, nxt, cf, nf = nxt, cur, nf, cf
        else:
            out = nxt[:rows]
            out.fill(0.0)
            _csr_matvecs(rows, n_pad, B, ptr, ind, data[o:e], cf, out.reshape(-1))
            cur[scatter] = out
    return _natural(cur, plan)


def _natural(cur: np.ndarray, plan: Plan) -> np.ndarray:
    if plan.final_pos is not None:
        return cur[plan.final_pos]
    return cur if plan.n == plan.n_pad else cur[:plan.n].copy()


def plan_backward(Y: np.ndarray, G: np.ndarray, plan: Plan, angles: np.ndarray,
                  num_parameters: int, per_example: bool) -> np.ndarray:
    """Reverse pass as :func:`._unary_layers.backward` (``G`` ends as ``dL/dX``).

    Activations and gradients travel together as the rows ``[Y | G]`` of one (n, 2B) array,
    undone layer by layer with the transposed matrices; a layer's gate gradients
    ``g_j . u_i - g_i . u_j`` are read from its paired output rows. The outputs of up to
    ``_CHUNK_BYTES`` worth of dense layers are kept so that their batch sums are two
    ``einsum`` calls for the whole chunk.
    """
    n, n_pad = plan.n, plan.n_pad
    B = Y.shape[1]
    data = np.take(_table(angles), plan.bwd_src)
    W = np.zeros((n_pad, 2 * B))
    W[:n, :B] = Y
    W[:n, B:] = G
    chunk = max(2, min(_CHUNK_BYTES // W.nbytes, plan.num_dense + 1))
    buf = np.empty((chunk, n_pad, 2 * B))
    np.take(W, plan.final, axis=0, out=buf[0])
    tmp = np.empty_like(W)
    slot = 0  # buf[slot] holds the current activations
    pending: list[tuple] = []  # (slot, step) of dense layers whose dots wait for the chunk
    if per_example:
        grad = np.zeros((num_parameters, B))
    else:
        e = np.empty(plan.num_dots)
    ptr2 = plan.indptr[2]

    def flush(first, last):
        V = buf[first:last + 1].reshape(-1, 2, 2 * B)
        d1 = np.einsum("kb,kb->k", V[:, 1, B:], V[:, 0, :B])
        d1 -= np.einsum("kb,kb->k", V[:, 0, B:], V[:, 1, :B])
        for s, st in pending:
            a, L = (s - first) * (n_pad // 2), st.pidx.size
            e[st.dot_offset:st.dot_offset + L] = d1[a:a + L]
        pending.clear()

    for st in reversed(plan.steps):
        L = st.pidx.size
        cur = buf[slot]
        if per_example or not st.dense:
            V = cur if st.dense else np.take(cur, cast(np.ndarray, st.scatter), axis=0,
                                             out=tmp[:st.rows])
            V = V.reshape(-1, 2, 2 * B)[:L]
            ui, uj, gi, gj = V[:, 0, :B], V[:, 1, :B], V[:, 0, B:], V[:, 1, B:]
            if per_example:
                _per_example(grad, st, ui, uj, gi, gj)
            else:
                o = st.dot_offset
                np.einsum("kb,kb->k", gj, ui, out=e[o:o + L])
                e[o:o + L] -= np.einsum("kb,kb->k", gi, uj)
        else:
            pending.append((slot, st))
        o, r = st.offset, st.rows
        if st.dense:
            if slot + 1 == chunk:
                if pending:
                    flush(pending[0][0], slot)
                buf[0] = cur
                slot = 0
                cur = buf[0]
            _product(ptr2, n_pad, n_pad, plan.bwd_cols[o:o + 2 * r],
                     data[o:o + 2 * r], cur, buf[slot + 1])
            slot += 1
        else:
            out = W[:r]
            _product(ptr2[:r + 1], r, r, plan.bwd_cols[o:o + 2 * r], data[o:o + 2 * r],
                     tmp[:r], out)
            cur[st.scatter] = out
    if pending:
        flush(pending[0][0], slot)
    G[...] = buf[slot, :n, B:]
    if per_example:
        return grad
    weights = plan.dot_coef * e[plan.dot_keep]
    return np.bincount(plan.dot_pidx, weights=weights, minlength=num_parameters).astype(float)


def _per_example(grad, st, ui, uj, gi, gj) -> None:
    tr = slice(None) if st.trainable is None else st.trainable
    if st.trainable is not None and not st.trainable.size:
        return
    d = gj[tr] * ui[tr]
    d -= gi[tr] * uj[tr]
    d *= st.coefficient[tr][:, None]
    if st.unique:
        grad[st.pidx[tr]] += d
    else:
        np.add.at(grad, st.pidx[tr], d)


def rotate_columns(Z: np.ndarray, compiled, angles: np.ndarray) -> np.ndarray:
    """``O(angles) @ Z`` for the columns ``Z`` (n, B) of a :class:`.unary.UnaryCircuit`.

    With numba, the compiled gate loop of :mod:`._unary_kernels` (shared angles on a copy,
    per-column angles in place). Otherwise shared angles (G,) go through the circuit's plan (a
    new array); per-column angles (G, B) layer by layer (:func:`._unary_layers.rotate`, ``Z``
    rotated in place and returned).
    """
    if _unary_kernels.available():  # compiled: gate by gate in place (on a copy if shared)
        num_threads()  # one thread, but a bad QDENSITY_NUM_THREADS is refused on every path
        Z = np.array(Z, dtype=float, order="C", copy=angles.ndim == 1 or None)
        return _unary_kernels.givens(Z, compiled, angles)
    if angles.ndim == 2:
        rotate(Z, compiled.layers, angles)
        return Z
    return plan_rotate(Z, compiled._plan, angles)


def reverse(Y: np.ndarray, G: np.ndarray, compiled, angles: np.ndarray,
            per_example: bool) -> np.ndarray:
    """The reverse pass of :func:`rotate_columns` (see :func:`._unary_layers.backward`)."""
    if angles.ndim == 2:
        return backward(Y, G, compiled.layers, angles, compiled.num_parameters, per_example)
    return plan_backward(Y, G, compiled._plan, angles, compiled.num_parameters, per_example)
