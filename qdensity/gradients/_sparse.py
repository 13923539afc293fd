"""Sparse Jacobians of a density gradient (``density_gradient_plan(..., jacobian="sparse")``).

Read out as unary probabilities, a sub-unitary ``k`` has ``m = n`` outputs ``f_k,j`` and
``P_k`` parameters; when it is one moment of RBS gates on disjoint pairs (the round-robin
model by layers), output ``j`` depends only on the parameter of the gate on qubit ``j``
(Prop. 1: each gate's gradient observables live on its pair), so of the dense
``(B, m, P_k)`` Jacobian at most ``B m`` entries are nonzero: at ``n = 256`` the dense
Jacobians and their errors of the 255 moments hold 2.1 GB, the sparse ones a few MB.

Layout: ``scipy.sparse.csr_array`` of shape ``(B * m, P_k)``, row ``b * m + j`` holding
``d f_k,j(x_b) / d theta_k`` in sub-unitary ``k``'s parameter order, i.e. the dense array
reshaped to ``(B * m, P_k)``. A Jacobian and its standard errors share one sparsity pattern
(the entries where either is nonzero); the entries left out are exactly zero in the dense
layout. ``jac.toarray().reshape(B, m, P_k)`` gives the dense layout back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import sparse

__all__ = ["JACOBIAN_LAYOUTS", "DENSE_LIMIT_BYTES", "choose_layout", "outputs_to_sparse",
           "support_to_sparse", "dense_to_sparse", "jacobian_vjp", "add_sparse",
           "from_probabilities"]

#: ``density_gradient_plan``'s ``jacobian`` layouts (``"auto"``: :func:`choose_layout`).
JACOBIAN_LAYOUTS = ("auto", "dense", "sparse")

#: ``"auto"`` keeps the dense layout while the dense Jacobians and their errors together
#: would hold at most this many bytes (64 MiB), and builds the sparse layout above it.
DENSE_LIMIT_BYTES = 2**26


def choose_layout(layout: str, rows: int, outputs: int, parameters: int) -> str:
    """The layout ``"dense"`` or ``"sparse"`` that ``layout`` asks for.

    Parameters
    ----------
    layout : {"auto", "dense", "sparse"}
    rows, outputs : int
        ``B`` data rows and ``m`` outputs per sub-unitary.
    parameters : int
        ``sum_k P_k``, the sub-unitaries' parameters.

    Returns
    -------
    str
        ``layout`` itself unless ``"auto"``; then ``"dense"`` when the dense Jacobians and
        their errors (``2 * 8 * B * m * sum_k P_k`` bytes) fit in :data:`DENSE_LIMIT_BYTES`,
        else ``"sparse"`` (the round-robin model by moments at ``n = 64``, 16 rows: 33 MB,
        dense; at ``n = 256``: 2.1 GB, sparse).
    """
    if layout != "auto":
        return layout
    dense_bytes = 16 * int(rows) * int(outputs) * int(parameters)
    return "dense" if dense_bytes <= DENSE_LIMIT_BYTES else "sparse"


def _pair(rows: np.ndarray, cols: np.ndarray, value: np.ndarray, error: np.ndarray,
          shape: tuple[int, int]) -> tuple[sparse.csr_array, sparse.csr_array]:
    """Two CSR arrays with the same pattern; ``rows`` must be non-decreasing (no sort).
    Indices are 32-bit where they fit (scipy's own choice; half the memory of 64-bit)."""
    index = np.int32 if max(shape[0], shape[1], len(cols)) < 2**31 - 1 else np.int64
    indptr = np.zeros(shape[0] + 1, dtype=index)
    np.cumsum(np.bincount(rows, minlength=shape[0]), out=indptr[1:])
    cols = np.asarray(cols, dtype=index)
    return (sparse.csr_array((np.asarray(value, dtype=float), cols, indptr), shape=shape),
            sparse.csr_array((np.asarray(error, dtype=float), cols.copy(), indptr.copy()),
                             shape=shape))


def outputs_to_sparse(values: Sequence[np.ndarray], errors: Sequence[np.ndarray]
                      ) -> tuple[sparse.csr_array, sparse.csr_array]:
    """Per output ``t`` (``m`` of them) its value and error, each dense ``(B, P)``, as the
    ``(B * m, P)`` sparse Jacobian and error (row ``b * m + t``); only one output's ``(B, P)``
    is dense at a time (the caller's), never the ``(B, m, P)`` stack.

    Returns
    -------
    (scipy.sparse.csr_array, scipy.sparse.csr_array), each shape (B * m, P)
    """
    m = len(values)
    B, P = np.shape(values[0])
    rows, cols, vals, errs = [], [], [], []
    for t, (v, e) in enumerate(zip(values, errors, strict=True)):
        v, e = np.asarray(v, dtype=float), np.asarray(e, dtype=float)
        b, p = np.nonzero((v != 0) | (e != 0))  # row-major: b ascending
        rows.append(b * m + t)
        cols.append(p)
        vals.append(v[b, p])
        errs.append(e[b, p])
    r, c = np.concatenate(rows), np.concatenate(cols)
    order = np.argsort(r, kind="stable")  # per row, columns stay ascending
    return _pair(r[order], c[order], np.concatenate(vals)[order], np.concatenate(errs)[order],
                 (B * m, P))


def from_probabilities(grads, probs, shots) -> tuple[sparse.csr_array, sparse.csr_array]:
    """Per output ``t`` the gradient ``grads[t]`` (a ``_GradientCircuits``) and its error
    from the circuits' outcome probabilities ``probs`` (``shots`` per row, None: exact, zero
    error), in the sparse layout, one output's ``(B, P)`` at a time."""
    vals = [np.atleast_2d(g.gradient_from_probabilities(probs)) for g in grads]
    errs = [np.atleast_2d(g.standard_error(probs, shots)) if shots is not None
            else np.zeros_like(v) for g, v in zip(grads, vals, strict=True)]
    return outputs_to_sparse(vals, errs)


def dense_to_sparse(value: np.ndarray, error: np.ndarray
                    ) -> tuple[sparse.csr_array, sparse.csr_array]:
    """A dense ``(B, m, P)`` Jacobian and its errors in the sparse layout (for the
    parameter-shift plans, whose post-processing is dense per sub-unitary)."""
    value, error = np.asarray(value, dtype=float), np.asarray(error, dtype=float)
    B, m, P = value.shape
    flat_v, flat_e = value.reshape(B * m, P), error.reshape(B * m, P)
    r, c = np.nonzero((flat_v != 0) | (flat_e != 0))
    return _pair(r, c, flat_v[r, c], flat_e[r, c], (B * m, P))


def support_to_sparse(mean: np.ndarray, se: np.ndarray, support: np.ndarray, m: int,
                      P: int) -> tuple[sparse.csr_array, sparse.csr_array]:
    """The estimates of the columns ``support`` (ascending indices ``t * P + p`` of output
    ``t``'s parameter ``p``), each ``(B, S)``, in the sparse layout (the other columns are
    zero with zero error)."""
    B, S = mean.shape
    t, p = np.divmod(np.asarray(support, dtype=np.int64), P)
    rows = (np.arange(B, dtype=np.int64)[:, None] * m + t[None, :]).ravel()
    cols = np.broadcast_to(p, (B, S)).ravel()
    return _pair(rows, cols, mean.ravel(), se.ravel(), (B * m, P))


def add_sparse(parts: Sequence[tuple[sparse.csr_array, sparse.csr_array]]
               ) -> tuple[sparse.csr_array, sparse.csr_array]:
    """Independent circuits' estimates: values add, variances add (as the dense path)."""
    value, error = parts[0]
    var = error.power(2)
    for v, e in parts[1:]:
        value = value + v
        var = var + e.power(2)
    return sparse.csr_array(value), sparse.csr_array(var).sqrt()


def jacobian_vjp(jacobian, weights: np.ndarray) -> np.ndarray:
    """``sum_{b, j} weights[b, j] jacobian[b, j, :]`` for a dense ``(B, m, P)`` Jacobian or a
    sparse ``(B * m, P)`` one.

    Parameters
    ----------
    jacobian : numpy.ndarray (B, m, P) or scipy.sparse array (B * m, P)
    weights : numpy.ndarray, shape (B, m)

    Returns
    -------
    numpy.ndarray, shape (P,)
    """
    if isinstance(jacobian, sparse.sparray | sparse.spmatrix):
        flat = np.asarray(weights, dtype=float).ravel()
        return np.asarray(flat @ jacobian).ravel()  # (B * m,) @ (B * m, P)
    return np.einsum("bm,bmp->p", weights, jacobian)
