"""Input checks of the unary engine (:mod:`.unary`): shapes, real and finite numbers."""

from __future__ import annotations

import numpy as np

from qdensity.validation import check_parameter_values

__all__: list[str] = []


def values(compiled, values, name: str = "values") -> np.ndarray:
    """Parameter values (P,) or (B, P) of a :class:`.unary.UnaryCircuit` (``None``: P = 0)."""
    if values is None:
        if compiled.num_parameters:
            raise ValueError(f"{name} is required: the circuit has {compiled.num_parameters} "
                             "parameters")
        values = np.zeros(0)
    return check_parameter_values(values, compiled.num_parameters, name)


def inputs(compiled, X, name: str = "X") -> np.ndarray:
    """Unary amplitudes (n,) or (B, n): real, finite, ``n`` the circuit's width."""
    if np.iscomplexobj(X):
        raise TypeError(f"{name} must be real (the unary engine is real-orthogonal), got complex")
    try:
        arr = np.asarray(X, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {X!r}") from exc
    n = compiled.num_qubits
    if arr.ndim not in (1, 2) or arr.shape[-1] != n:
        raise ValueError(f"{name} must have shape ({n},) or (batch, {n}) for a {n}-qubit "
                         f"circuit, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def batch(compiled, X, values_, xname: str = "X"):
    """Columns (n, B) of inputs, angles (G,) or (G, B), whether the output is 1-d."""
    x2, angles, single = rows(compiled, X, values_, xname)
    return np.array(x2.T, dtype=float, order="C"), angles, single


def rows(compiled, X, values_, xname: str = "X"):
    """Rows (B, n) of inputs (C-contiguous float64), angles (G,) or (G, B), whether the output
    is 1-d."""
    x2, v, single = rows_values(compiled, X, values_, xname)
    return x2, compiled.angles(v), single


def rows_values(compiled, X, values_, xname: str = "X", declared: bool = False):
    """Rows (B, n) of inputs (C-contiguous float64), values (P,) or (B, P), whether the output
    is 1-d. ``declared``: the caller's declarations have checked that ``X`` and ``values_``
    are real and finite (float64 arrays of the right widths then skip the checks here)."""
    if (declared and type(X) is np.ndarray and type(values_) is np.ndarray
            and X.dtype == np.float64 and values_.dtype == np.float64 and X.ndim == 2
            and values_.ndim == 1 and X.shape[1] == compiled.num_qubits
            and values_.shape[0] == compiled.num_parameters and X.flags.c_contiguous
            and values_.flags.c_contiguous):
        return X, values_, False
    x = inputs(compiled, X, xname)
    v = values(compiled, values_)
    single = x.ndim == 1 and v.ndim == 1
    if v.ndim == 2:
        if x.ndim == 1:
            x = np.broadcast_to(x, (v.shape[0], x.size))
        elif x.shape[0] != v.shape[0]:
            raise ValueError(
                f"values has {v.shape[0]} rows but {xname} has {x.shape[0]} rows; give one "
                "parameter row per input, or values of shape (P,) shared by the batch"
            )
    # C-contiguous values too: one compiled specialization of the kernels, not one per layout
    return np.ascontiguousarray(np.atleast_2d(x), dtype=float), np.ascontiguousarray(v), single
