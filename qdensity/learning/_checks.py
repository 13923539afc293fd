"""Input checks shared by the classical layers of :mod:`qdensity.learning.nn` (Fig. 11).

Every layer's ``forward`` takes a batch through :func:`_check_batch` and every ``backward``
takes the incoming gradient through :func:`_check_grad`, so the error messages are the same
for all layers.
"""

from __future__ import annotations

import numpy as np


def _check_batch(X, name: str, features: int | None = None) -> np.ndarray:
    """A finite float64 array of shape ``(B, d)`` with ``B >= 1`` (and ``d == features``)."""
    try:
        arr = np.asarray(X, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {X!r}") from exc
    want = "(batch, features)" if features is None else f"(batch, {features})"
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-dimensional with shape {want}, got shape {arr.shape}")
    if arr.shape[0] < 1:
        raise ValueError(f"{name} must hold at least one row, got shape {arr.shape}")
    if features is not None and arr.shape[1] != features:
        raise ValueError(f"{name} must have shape {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def _check_grad(grad_Y, shape: tuple[int, ...], name: str = "grad_Y") -> np.ndarray:
    """A finite float64 array with exactly the shape of the layer's last output."""
    try:
        arr = np.asarray(grad_Y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {grad_Y!r}") from exc
    if arr.shape != shape:
        raise ValueError(
            f"{name} must have the shape of the last forward output {shape}, got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr
