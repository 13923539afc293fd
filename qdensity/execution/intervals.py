"""Standard errors of sampled estimates that never collapse to zero (Wilson's term, z = 1).

The plug-in binomial error ``sqrt(p_hat (1 - p_hat) / N)`` is zero whenever an outcome never
(or always) turned up in ``N`` shots, and a zero error claims certainty: an interval
``p_hat +- k * se`` of width zero, and a Neyman allocation that starves the stratum. The Wilson
score interval (Wilson 1927) at ``z = 1`` has half-width
``sqrt(p_hat (1 - p_hat) / N + 1 / (4 N^2)) / (1 + 1 / N)``; qdensity keeps its extra term
``1 / (4 N^2)`` and drops the shrink factor ``1 / (1 + 1 / N)``:

    ``se = sqrt(p_hat (1 - p_hat) / N + 1 / (4 N^2))``,

which is never below the plug-in error nor below Wilson's half-width, differs from both by
``O(1/N)``, and is at least ``1 / (2 N)``. For a per-shot value bounded in an interval of width
``R`` (an observable's eigenvalues, a gradient estimator's values) the sample variance replaces
``p_hat (1 - p_hat)`` and ``R^2 / (4 N^2)`` is the extra term (for values in ``{0, R}`` this is
the binomial case scaled by ``R``). Every sampled standard error in qdensity (plans, gradients,
schedulers, models) goes through :func:`wilson_standard_error`.
"""

from __future__ import annotations

import numpy as np

from qdensity.validation import Array, Interval, refuse, validates

__all__ = ["wilson_standard_error", "binomial_standard_error", "shot_mean"]


def wilson_standard_error(variance, shots, value_range_width=1.0) -> np.ndarray:
    """Standard error of the mean of ``shots`` bounded per-shot values, never zero.

    Parameters
    ----------
    variance : array_like
        Per-shot variance estimate (plug-in or unbiased), any shape; negative rounding noise
        is clipped to zero.
    shots : int or array_like of int
        Shots behind each mean (broadcast against ``variance``), ``>= 1``.
    value_range_width : float or array_like
        Width ``R = high - low`` of the interval each per-shot value lies in (broadcast).

    Returns
    -------
    numpy.ndarray
        ``sqrt(variance / N + R^2 / (4 N^2))``, strictly positive when ``R > 0``.

    Examples
    --------
    >>> float(wilson_standard_error(0.0, 2000))  # an outcome never seen in 2000 shots
    0.00025
    >>> round(float(wilson_standard_error(0.25, 10_000)), 7)  # p = 1/2: plug-in is 0.005
    0.0050002
    """
    var = np.maximum(np.asarray(variance, dtype=float), 0.0)
    n = np.asarray(shots, dtype=float)
    if np.any(n < 1):
        raise ValueError(f"shots must be >= 1, got {shots!r}")
    width = np.asarray(value_range_width, dtype=float)
    return np.sqrt(var / n + width**2 / (4.0 * n**2))


@validates(p=Array(ndim=None, min_size=0),
           shots=[Interval(int, 1), Array(ndim=None, dtype="int", min_size=0)])
def binomial_standard_error(p, shots) -> np.ndarray:
    """Standard error of an outcome frequency ``p_hat`` from ``shots`` shots, never zero.

    Parameters
    ----------
    p : array_like
        Empirical frequencies in ``[0, 1]``.
    shots : int or array_like of int

    Returns
    -------
    numpy.ndarray
        Same shape as ``p``; never zero.

    Examples
    --------
    >>> float(binomial_standard_error(0.0, 100))
    0.005
    """
    p = np.asarray(p, dtype=float)
    if np.any((p < 0) | (p > 1)):
        raise refuse("binomial_standard_error", "p", p, "frequencies in [0, 1]")
    return wilson_standard_error(p * (1.0 - p), shots, 1.0)


def shot_mean(per_shot, value_range_width=1.0, *, weights=None, effective_shots=None,
              ddof: int = 0, linearisations=None) -> tuple[np.ndarray, np.ndarray]:
    """Mean over shots of per-shot values and its standard error, raw or corrected.

    Raw: the sample mean, error :func:`wilson_standard_error` of the sample variance. With
    ``weights`` (readout mitigation and post-selection, see
    :class:`~qdensity.execution.engines.SamplerEngine`): the value is
    ``mean_s w_s x_s = sum_b q(b) x(b)`` with ``q`` the corrected distribution, and the error
    ``sqrt(var + R^2 / (4 n^2))``: ``var`` is a row's linearisation's delta-method
    variance when given (readout mitigation: shots and calibration, see
    :class:`~qdensity.execution.engines.SamplerEngine`; ``n`` its kept shots ``min(kappa, 1)
    N``), else ``Var_q(x) / N_eff`` (``n = N_eff``) with
    ``Var_q`` taken over ``q`` clipped to non-negative weights and ``N_eff = kappa N / M`` the
    effective shots (kept fraction ``kappa``, mitigation overhead ``M``; exact for
    post-selection alone, where ``M = 1``).

    Parameters
    ----------
    per_shot : array_like, shape (rows, shots) or (rows, shots, k)
    value_range_width : float or array_like
        Width ``R`` of the interval each per-shot value lies in (broadcast against the mean).
    weights : array_like, shape (rows, shots), optional
        Per-shot weights with mean 1 per row.
    effective_shots : array_like, shape (rows,), optional
        ``N_eff`` per row (required with ``weights``).
    ddof : int
        Degrees of freedom of the raw sample variance.
    linearisations : sequence, length rows, optional
        Per row, an object whose ``variance(per_shot_row, mean_row)`` gives the row's
        variance (``JobResult.readout``); a None entry falls back to ``N_eff``.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Mean and standard error, each shape (rows,) or (rows, k).

    Examples
    --------
    >>> m, se = shot_mean([[1.0, -1.0, 1.0, 1.0]], 2.0)
    >>> float(m[0])
    0.5
    >>> m, _ = shot_mean([[1.0, -1.0]], 2.0, weights=[[1.5, 0.5]], effective_shots=[2.0])
    >>> float(m[0])
    0.5
    """
    x = np.asarray(per_shot, dtype=float)
    if weights is None:
        return x.mean(axis=1), wilson_standard_error(x.var(axis=1, ddof=ddof), x.shape[1],
                                                     value_range_width)
    w = np.asarray(weights, dtype=float)
    if w.shape != x.shape[:2]:
        raise ValueError(f"weights must have shape {x.shape[:2]} (rows, shots), got {w.shape}")
    n_eff = np.asarray(effective_shots, dtype=float)
    if n_eff.shape != (x.shape[0],) or np.any(n_eff <= 0):
        raise ValueError(f"effective_shots must be {x.shape[0]} positive numbers, got "
                         f"{effective_shots!r}")
    wx = w.reshape(w.shape + (1,) * (x.ndim - 2))
    mean = (wx * x).mean(axis=1)
    q = np.clip(wx, 0.0, None)
    q = q / np.maximum(q.sum(axis=1, keepdims=True), 1e-300)
    var = np.maximum((q * x**2).sum(axis=1) - (q * x).sum(axis=1) ** 2, 0.0)
    n = n_eff.reshape((-1,) + (1,) * (x.ndim - 2))
    var = var / n
    floor = n.copy()
    if linearisations is not None:
        if len(linearisations) != x.shape[0]:
            raise ValueError(f"linearisations must have {x.shape[0]} entries (one per row), "
                             f"got {len(linearisations)}")
        for r, lin in enumerate(linearisations):
            if lin is not None:
                var[r] = lin.variance(x[r], mean[r])
                floor[r] = lin.kept_shots  # not N / M: the overhead is in var already
    width = np.asarray(value_range_width, dtype=float)
    return mean, np.sqrt(var + width**2 / (4.0 * floor**2))
