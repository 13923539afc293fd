"""The unary engine on torch tensors: the same layers of Givens rotations, on any device.

:func:`forward`, :func:`vjp` and :func:`jacobian` of :mod:`qdensity.execution.unary` come here
when one of their arrays is a ``torch.Tensor``; the results are tensors on that tensor's
device and of its dtype (float32 or float64). The work is the numpy path's
(:mod:`._layers`): the gates grouped into layers of disjoint rotations, one layer a handful of
tensor operations on all its pairs and all columns at once,

    W = Z[rows] = [z_i; z_j],   Z[rows] = C W + S roll(W),   C = [c; c],  S = [-s; s],

so a call launches ``O(depth)`` kernels, never one per gate or per row. The reverse pass
(paper Methods, "Backpropagation scaling") undoes the layers on ``[Y | G]`` together and reads
each gate's derivative ``g_j u_i - g_i u_j`` from the pairs it gathered; nothing is stored per
layer. Index tables are built once per circuit and device.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution._torch import cache_of, check_fits, is_tensor, real_dtype, torch

__all__: list[str] = []


def any_tensor(*arrays) -> bool:
    """Whether one of ``arrays`` is a torch tensor (the dispatch test of the public functions)."""
    return any(is_tensor(a) for a in arrays)


def _reference(*arrays):
    """Device and dtype of the first tensor among ``arrays``."""
    for a in arrays:
        if is_tensor(a):
            if a.is_complex():
                raise TypeError("unary engine tensors must be real (the unary engine is "
                                f"real-orthogonal), got dtype {a.dtype}")
            return a.device, real_dtype(a)
    raise TypeError("no tensor among the arrays")  # pragma: no cover - callers dispatch


def _tensor(a, name: str, device, dtype):
    """``a`` (tensor or array_like) as a real tensor on ``device`` of ``dtype``, finite."""
    t = torch()
    if is_tensor(a):
        if a.is_complex():
            raise TypeError(f"{name} must be real (the unary engine is real-orthogonal), got "
                            f"dtype {a.dtype}")
        if not a.is_floating_point():
            raise TypeError(f"{name} must be a float32 or float64 tensor, got dtype {a.dtype}")
        out = a.detach().to(device=device, dtype=dtype)
    else:
        if np.iscomplexobj(a):
            raise TypeError(f"{name} must be real (the unary engine is real-orthogonal), got "
                            "complex")
        try:
            arr = np.asarray(a, dtype=float)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be an array of real numbers, got {a!r}") from exc
        out = t.as_tensor(arr, dtype=dtype, device=device)
    if out.device.type != "meta" and out.numel() and not bool(t.isfinite(out).all()):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return out


def _inputs(compiled, X, name, device, dtype):
    x = _tensor(X, name, device, dtype)
    n = compiled.num_qubits
    if x.ndim not in (1, 2) or x.shape[-1] != n:
        raise ValueError(f"{name} must have shape ({n},) or (batch, {n}) for a {n}-qubit "
                         f"circuit, got {tuple(x.shape)}")
    return x


def _values(compiled, values, device, dtype):
    P = compiled.num_parameters
    if values is None:
        if P:
            raise ValueError(f"values is required: the circuit has {P} parameters")
        return torch().zeros(0, dtype=dtype, device=device)
    v = _tensor(values, "values", device, dtype)
    if v.ndim not in (1, 2) or v.shape[-1] != P:
        raise ValueError(f"values must have shape ({P},) or (rows, {P}), got {tuple(v.shape)}")
    return v


def _batch(compiled, X, values, device, dtype, xname="X"):
    """Columns (n, B), angles (G,) or (G, B), whether the output is 1-d (as ``_inputs.batch``)."""
    x = _inputs(compiled, X, xname, device, dtype)
    v = _values(compiled, values, device, dtype)
    single = x.ndim == 1 and v.ndim == 1
    if v.ndim == 2:
        if x.ndim == 1:
            x = x.expand(v.shape[0], x.shape[0])
        elif x.shape[0] != v.shape[0]:
            raise ValueError(
                f"values has {v.shape[0]} rows but {xname} has {x.shape[0]} rows; give one "
                "parameter row per input, or values of shape (P,) shared by the batch")
    x2 = x if x.ndim == 2 else x[None, :]
    check_fits(device, 4 * x2.numel() * x2.element_size(), "the unary engine's columns")
    # a copy always: the layers rotate the columns in place, and for one row ``x2.T`` is
    # already contiguous (``.contiguous()`` would hand back the caller's own tensor)
    Z = x2.T.clone(memory_format=torch().contiguous_format)
    return Z, _angles(compiled, v, device, dtype), single


class _Tables:
    """Index tensors of one circuit on one device (layer order, see the module docstring)."""

    def __init__(self, compiled, device, dtype):
        t = torch()
        layers = compiled.layers
        self.sizes = [int(layer.gates.size) for layer in layers]
        gates = [layer.gates for layer in layers]
        order = np.concatenate(gates) if gates else np.zeros(0, dtype=np.intp)
        as_long = lambda a: t.as_tensor(np.asarray(a, dtype=np.int64), device=device)  # noqa: E731
        self.rows2 = as_long(np.concatenate([layer.rows for layer in layers]) if layers else [])
        # [first; second; second; first] per layer: a layer's pairs and their swap, one gather
        self.rows4 = as_long(np.concatenate([np.concatenate([layer.rows,
                                                             np.roll(layer.rows, g.size)])
                                             for layer, g in zip(layers, gates, strict=True)])
                             if layers else [])
        self.gates2 = as_long(np.concatenate([np.concatenate([g, g]) for g in gates])
                              if gates else [])
        sgn = [np.concatenate([-np.ones(g.size), np.ones(g.size)]) for g in gates]
        self.sgn2 = t.as_tensor(np.concatenate(sgn) if sgn else np.zeros(0), dtype=dtype,
                                device=device)
        free = compiled.parameter_index[order] >= 0
        self.pidx = as_long(np.where(free, compiled.parameter_index[order], 0))
        self.coef = t.as_tensor(np.where(free, compiled.coefficient[order], 0.0), dtype=dtype,
                                device=device)
        idx, scale = compiled._angle_map
        self.idx = as_long(idx)
        self.scale = t.as_tensor(scale, dtype=dtype, device=device)
        self.offset = t.as_tensor(compiled.offset, dtype=dtype, device=device)


def _tables(compiled, device, dtype) -> _Tables:
    cache = cache_of(compiled)
    key = (str(device), str(dtype))
    tab = cache.get(key)
    if tab is None:
        tab = cache[key] = _Tables(compiled, device, dtype)
    return tab


def _angles(compiled, v, device, dtype):
    """Gate angles (G,) or (G, B) for values (P,) or (B, P), on the device."""
    tab = _tables(compiled, device, dtype)
    if v.shape[-1] == 0:
        picked = torch().zeros((compiled.num_gates,) + tuple(v.shape[:-1]), dtype=dtype,
                               device=device)
    elif v.ndim == 1:
        picked = v.index_select(0, tab.idx)
    else:
        picked = v.index_select(1, tab.idx).T
    if picked.ndim == 2:
        return tab.scale[:, None] * picked + tab.offset[:, None]
    return tab.scale * picked + tab.offset


def _trig(tab, angles, shared, a, b):
    """``C = [c; c]`` and ``S = [-s; s]`` of the layer at ``[a, b)`` of the 2G tables:
    slices of ``shared`` (every gate's, built once per call) for angles (G,), else (2L, B)."""
    if shared is not None:
        return shared[0][a:b, None], shared[1][a:b, None]
    ang = angles.index_select(0, tab.gates2[a:b])
    return ang.cos(), ang.sin() * tab.sgn2[a:b, None]


def _shared_trig(tab, angles):
    """For angles (G,) shared by the columns: C and S of every gate in layer order, (2G,)."""
    if angles.ndim != 1:
        return None
    ang = angles.index_select(0, tab.gates2)
    return ang.cos(), ang.sin() * tab.sgn2


def rotate(Z, compiled, angles):
    """``O(angles) @ Z`` for columns ``Z`` (n, B), in place (``Z`` is returned)."""
    tab = _tables(compiled, Z.device, Z.dtype)
    shared = _shared_trig(tab, angles)
    a = 0
    for L in tab.sizes:
        b = a + 2 * L
        r = tab.rows2[a:b]
        C, S = _trig(tab, angles, shared, a, b)
        W = Z.index_select(0, tab.rows4[2 * a:2 * b])  # [z_i; z_j; z_j; z_i]
        new = W[:2 * L] * C
        new.addcmul_(W[2 * L:], S)
        Z.index_copy_(0, r, new)
        a = b
    return Z


def _forward_columns(compiled, Z, angles):
    n, B = Z.shape
    if angles.ndim == 1 and B > n:  # O once, then one product (as the numpy path)
        eye = torch().eye(n, dtype=Z.dtype, device=Z.device)
        return rotate(eye, compiled, angles) @ Z
    return rotate(Z, compiled, angles)


def backward(Y, G, compiled, angles, per_example: bool):
    """Reverse pass from outputs ``Y`` and output gradients ``G`` (both (n, B)).

    Returns the parameter gradient, (P, B) when ``per_example`` else (P,), and ``dL/dX`` as
    columns (n, B)."""
    t = torch()
    tab = _tables(compiled, Y.device, Y.dtype)
    n, B = Y.shape
    P = compiled.num_parameters
    YG = t.cat([Y, G], dim=1)
    shared = _shared_trig(tab, angles)
    grad = t.zeros((P, B) if per_example else (P,), dtype=Y.dtype, device=Y.device)
    per_gate = None if per_example or not P else t.empty(compiled.num_gates, dtype=Y.dtype,
                                                         device=Y.device)
    b = 2 * compiled.num_gates
    for L in reversed(tab.sizes):
        a = b - 2 * L
        o = a // 2
        r = tab.rows2[a:b]
        W4 = YG.index_select(0, tab.rows4[2 * a:2 * b])  # rows [i; j; j; i], columns [u | g]
        W, Wr = W4[:2 * L], W4[2 * L:]
        if P and per_example:
            d = W[L:, B:] * W[:L, :B]
            d -= W[:L, B:] * W[L:, :B]
            grad.index_add_(0, tab.pidx[o:o + L], d * tab.coef[o:o + L, None])
        elif P:  # rows [u_i g_j; u_j g_i] summed over the batch, then first minus second
            sums = (W[:, :B] * Wr[:, B:]).sum(dim=1)
            assert per_gate is not None  # allocated whenever P and not per_example
            t.sub(sums[:L], sums[L:], out=per_gate[o:o + L])
        C, S = _trig(tab, angles, shared, a, b)
        if C.shape[1] != 1:
            C, S = t.cat([C, C], dim=1), t.cat([S, S], dim=1)
        new = W * C
        new.addcmul_(Wr, S, value=-1.0)
        YG.index_copy_(0, r, new)
        b = a
    if per_gate is not None:
        grad.index_add_(0, tab.pidx, tab.coef * per_gate)
    return grad, YG[:, B:]


def _recording(*arrays) -> bool:
    """Grad mode is on and one of ``arrays`` is a tensor that requires a gradient."""
    return torch().is_grad_enabled() and any(is_tensor(a) and a.requires_grad for a in arrays)


def differentiable_columns(compiled, X, values):
    """``forward`` of tensors ``X`` (n,) or (B, n) and ``values`` (P,), (B, P) or None, by
    out-of-place tensor operations only, so that torch's autograd differentiates it to any
    order (it keeps every layer's columns: the recomputation a second derivative needs, not
    the first-order path)."""
    device, dtype = _reference(X, values)
    x = X.to(device=device, dtype=dtype) if is_tensor(X) else _tensor(X, "X", device, dtype)
    v = (values.to(device=device, dtype=dtype) if is_tensor(values)
         else _values(compiled, values, device, dtype))
    single = x.ndim == 1 and v.ndim == 1
    if v.ndim == 2 and x.ndim == 1:
        x = x.expand(v.shape[0], x.shape[0])
    Z = (x if x.ndim == 2 else x[None, :]).T
    angles = _angles(compiled, v, device, dtype)
    tab = _tables(compiled, device, dtype)
    a = 0
    for L in tab.sizes:
        b = a + 2 * L
        ang = angles.index_select(0, tab.gates2[a:b])
        C, S = ang.cos(), ang.sin() * (tab.sgn2[a:b] if ang.ndim == 1 else tab.sgn2[a:b, None])
        if ang.ndim == 1:
            C, S = C[:, None], S[:, None]
        W = Z.index_select(0, tab.rows4[2 * a:2 * b])  # [z_i; z_j; z_j; z_i]
        Z = Z.index_copy(0, tab.rows2[a:b], W[:2 * L] * C + W[2 * L:] * S)
        a = b
    return Z[:, 0] if single else Z.T


_FUNCTION: list = []


def _function():
    """The ``torch.autograd.Function`` of :func:`forward` (made on first use: torch is
    optional)."""
    if _FUNCTION:
        return _FUNCTION[0]
    t = torch()

    class UnaryForward(t.autograd.Function):  # type: ignore[name-defined]  # torch is lazy
        """``(X, values) -> forward(compiled, X, values)`` with the reverse pass as backward,
        and autograd through :func:`differentiable_columns` for higher derivatives."""

        @staticmethod
        def forward(ctx, X, values, compiled):
            y = _plain_forward(compiled, X, values)
            ctx.compiled = compiled
            ctx.arrays = (None if is_tensor(X) else X, None if is_tensor(values) else values)
            ctx.save_for_backward(X if is_tensor(X) else None,
                                  values if is_tensor(values) else None, y)
            return y

        @staticmethod
        def backward(ctx, grad_y):
            X, values, y = ctx.saved_tensors
            X = ctx.arrays[0] if X is None else X
            values = ctx.arrays[1] if values is None else values
            need_x, need_v = ctx.needs_input_grad[0], ctx.needs_input_grad[1]
            if t.is_grad_enabled():  # create_graph: a graph of the gradient, to any order
                wrt = [a for a, need in ((X, need_x), (values, need_v)) if need]
                with t.enable_grad():
                    out = differentiable_columns(ctx.compiled, X, values)
                    grads = list(t.autograd.grad(out, wrt, grad_y, create_graph=True,
                                                 allow_unused=True))
                g_x = grads.pop(0) if need_x else None
                g_v = grads.pop(0) if need_v else None
                return g_x, g_v, None
            per_row = is_tensor(values) and values.ndim == 2 or (
                not is_tensor(values) and values is not None and np.ndim(values) == 2)
            xd = X.detach() if is_tensor(X) else X
            vd = values.detach() if is_tensor(values) else values
            g_v, g_x = vjp(ctx.compiled, xd, vd, grad_y.detach(),
                           "none" if per_row else "sum", y.detach())
            if need_x and g_x.ndim == 2 and X.ndim == 1:  # one input under every row
                g_x = g_x.sum(dim=0)
            return (g_x.to(X.dtype) if need_x else None,
                    g_v.to(values.dtype) if need_v else None, None)

    _FUNCTION.append(UnaryForward)
    return UnaryForward


def forward(compiled, X, values):
    """:func:`qdensity.execution.unary.forward` on tensors (see there); recorded by autograd
    when ``X`` or ``values`` requires a gradient (module docstring)."""
    if _recording(X, values):
        return _function().apply(X, values, compiled)
    return _plain_forward(compiled, X, values)


def _refuse_recording(name: str, *arrays) -> None:
    if _recording(*arrays):
        raise ValueError(f"{name} of the unary engine returns plain tensors: an input that "
                         "requires a gradient would get none through it. Differentiate "
                         "qdensity.execution.unary.forward with torch.autograd instead (any "
                         "order), or call this under torch.no_grad() or on detached tensors")


def _plain_forward(compiled, X, values):
    device, dtype = _reference(X, values)
    Z, angles, single = _batch(compiled, X, values, device, dtype)
    Z = _forward_columns(compiled, Z, angles)
    return Z[:, 0].clone() if single else Z.T.contiguous()


def vjp(compiled, X, values, grad_Y, reduce: str = "none", outputs=None):
    """:func:`qdensity.execution.unary.vjp` on tensors (see there)."""
    _refuse_recording("vjp", X, values, grad_Y, outputs)
    device, dtype = _reference(X, values, grad_Y, outputs)
    Z, angles, single = _batch(compiled, X, values, device, dtype)
    n, B = Z.shape
    gy = _tensor(grad_Y, "grad_Y", device, dtype)
    expected = (n,) if single else (B, n)
    if tuple(gy.shape) != expected:
        raise ValueError(f"grad_Y must have the output's shape {expected}, got "
                         f"{tuple(gy.shape)}")
    per_example = reduce == "none" and not single
    if per_example:
        check_fits(device, compiled.num_parameters * B * Z.element_size(),
                   "the per-example gradients (reduce='none')")
    G = (gy[:, None] if single else gy.T).contiguous()
    if outputs is not None:
        shape = tuple(outputs.shape) if is_tensor(outputs) else np.shape(outputs)
        if shape != expected:
            raise ValueError(f"outputs must have the output's shape {expected}, got {shape}")
        y = _tensor(outputs, "outputs", device, dtype)
        Y = (y[:, None] if single else y.T).contiguous()
    else:
        Y = _forward_columns(compiled, Z, angles)
    grad_p, GX = backward(Y, G, compiled, angles, per_example)
    if single:
        return grad_p, GX[:, 0].clone()
    return (grad_p.T.contiguous() if per_example else grad_p), GX.T.contiguous()


def jacobian(compiled, x, values):
    """:func:`qdensity.execution.unary.jacobian` on tensors (see there)."""
    _refuse_recording("jacobian", x, values)
    device, dtype = _reference(x, values)
    xt = _inputs(compiled, x, "x", device, dtype)
    if xt.ndim != 1:
        raise ValueError(f"x must have shape ({compiled.num_qubits},), got {tuple(xt.shape)}")
    v = _values(compiled, values, device, dtype)
    if v.ndim != 1:
        raise ValueError(f"values must have shape ({compiled.num_parameters},), got "
                         f"{tuple(v.shape)}")
    n = compiled.num_qubits
    eye = torch().eye(n, dtype=dtype, device=device)
    grad_values, _ = vjp(compiled, xt.expand(n, n), v, eye)
    return grad_values
