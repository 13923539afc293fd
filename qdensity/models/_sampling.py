"""Per-shot values for ``DensityQNN.sample``'s schedulers, raw or from a corrected engine.

A mitigated or post-selected :class:`~qdensity.execution.engines.SamplerEngine` weights every
shot (``JobResult.weights``, mean 1 per row): the per-shot value ``h(b_s) w_s`` has the
corrected mean. Its range is the observable's widened by :data:`WEIGHT_BOUND` (weights may be
negative); a larger weight is refused rather than clipped.
"""

from __future__ import annotations

import numpy as np

__all__ = ["WEIGHT_BOUND", "shot_values", "corrected_range"]

#: Largest per-shot weight of a corrected run the schedulers accept.
WEIGHT_BOUND = 4.0


def corrected_range(lo: float, hi: float) -> tuple[float, float]:
    """The range of ``h(b) w`` for ``h`` in ``[lo, hi]`` and ``|w| <= WEIGHT_BOUND``."""
    bound = WEIGHT_BOUND * max(abs(lo), abs(hi))
    return -bound, bound


def shot_values(result, values: np.ndarray, shots: int, k: int) -> np.ndarray:
    """Per-shot values ``h(b_s)`` (times the shot weights of a corrected run) of one job's
    first row; exact probabilities are turned into ``shots`` values by rounding counts."""
    if result.bits is None:
        counts = np.rint(result.probabilities[0] * shots).astype(int)
        return values[np.repeat(np.arange(counts.size), counts)]
    out = values[result.bits[0] @ (1 << np.arange(result.bits.shape[-1]))]
    if result.weights is None:
        return out
    w = result.weights[0]
    if np.abs(w).max() > WEIGHT_BOUND:
        raise ValueError(f"a corrected shot of sub-unitary {k} has weight "
                         f"{np.abs(w).max():.3g} > {WEIGHT_BOUND} (a kept fraction or a "
                         f"mitigated frequency far below the raw one); spend more shots")
    return out * w
