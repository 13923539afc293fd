"""Private helpers shared by the schedulers, the allocations and the shot sources (Supp. I).

Input checks (value range, budget, shot counts), :func:`_draw` -- the checked call to a shot
source -- and the per-sub-unitary sample means and variances the estimators are built from.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from qdensity.execution.schedulers.base import ShotSource
from qdensity.validation import check_callable, check_positive_int


def _check_value_range(value_range) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value_range)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"value_range must be a pair (low, high) of real numbers, got {value_range!r}"
        ) from exc
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(
            f"value_range must be finite with low < high (the range every per-shot value lies "
            f"in, e.g. (-1, 1) for a Pauli observable), got {value_range!r}"
        )
    return lo, hi


def _check_budget(budget, needed: int, why: str) -> int:
    budget = check_positive_int(budget, "budget")
    if budget < needed:
        raise ValueError(f"budget must be >= {needed} ({why}), got {budget}")
    return budget


def _check_shots(shots, num: int, name: str = "shots_per_k") -> np.ndarray:
    arr = np.asarray(shots)
    if arr.shape != (num,):
        raise ValueError(
            f"{name} must have shape ({num},) (one entry per sub-unitary), got {arr.shape}"
        )
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        if not (np.issubdtype(arr.dtype, np.floating) and np.all(arr == np.round(arr))):
            raise TypeError(f"{name} must hold integers, got {shots!r}")
    arr = arr.astype(np.int64)
    if np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative, got {arr}")
    return arr


def _draw(
    source: ShotSource,
    shots: np.ndarray,
    rng: np.random.Generator,
    value_range: tuple[float, float],
    phase: str | None = None,
) -> list[np.ndarray]:
    """Call ``source`` and check what comes back (count, lengths, finiteness, range).

    ``phase`` (``"pilot"`` or ``"main"``, two-phase schedulers only) is passed on to a source
    that takes a ``phase`` keyword, so it can label its shots (e.g. in a ``ShotLedger``).
    """
    check_callable(source, "source", "a callable source(shots_per_k, rng) -> K value arrays "
                   "(e.g. sampler_source or discrete_source)")
    if phase is not None and _takes_phase(source):
        out = source(shots.copy(), rng, phase=phase)
    else:
        out = source(shots.copy(), rng)
    try:
        out = list(out)
    except TypeError as exc:
        raise ValueError(
            f"source must return a sequence of {shots.size} value arrays, got {type(out).__name__}"
        ) from exc
    if len(out) != shots.size:
        raise ValueError(
            f"source returned {len(out)} value arrays, expected {shots.size} (one per sub-unitary)"
        )
    lo, hi = value_range
    checked = []
    for k, (vals, n) in enumerate(zip(out, shots, strict=True)):
        arr = np.asarray(vals, dtype=float)
        if arr.shape != (n,):
            raise ValueError(
                f"source returned values of shape {arr.shape} for sub-unitary {k}, "
                f"which was asked for {n} shots (expected shape ({n},))"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"source returned non-finite values for sub-unitary {k}")
        if arr.size and (arr.min() < lo or arr.max() > hi):
            raise ValueError(
                f"source returned values in [{arr.min()}, {arr.max()}] for sub-unitary {k}, "
                f"outside value_range ({lo}, {hi}); pass the observable's true value_range"
            )
        checked.append(arr)
    return checked


def _takes_phase(source) -> bool:
    try:
        params = inspect.signature(source).parameters
    except (TypeError, ValueError):  # builtins and some callables have no signature
        return False
    return "phase" in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def _means(values: list[np.ndarray]) -> np.ndarray:
    return np.array([v.mean() if v.size else np.nan for v in values])


def _sample_var(values: list[np.ndarray]) -> np.ndarray:
    """Unbiased sample variance per stratum (``NaN`` with fewer than two values)."""
    return np.array([v.var(ddof=1) if v.size >= 2 else np.nan for v in values])
