"""The statistics of the verdict rule: one test per kind of claim, and the seeds each needs.

Every function takes per-seed values (a paired difference, a slope, a margin) and returns plain
numbers; :mod:`qdensity_paper.verdicts` turns them into verdicts. Tests at level
``alpha = 0.05``:

* superiority: the paired difference's two-sided ``1 - alpha`` Student-t interval;
* non-inferiority at margin ``m``: one-sided t-test of ``H0: e <= -m`` (``e`` the difference
  signed so that the paper's side is positive), i.e. the lower end of the two-sided
  ``1 - 2 alpha`` interval above ``-m``;
* equivalence at margin ``m``: two one-sided tests (TOST), i.e. the ``1 - 2 alpha`` interval
  inside ``(-m, m)``;
* trend: the per-seed least-squares slope over the grid, judged as a superiority claim on the
  slopes (Page's rank test for ordered alternatives is reported beside it);
* bound: a theorem's margin, non-negative in every seed.

Sequential looks (:func:`spent`, :func:`look_levels`): a claim judged at several seed counts
(seeds added after an inconclusive look) spends its ``alpha`` over the looks by a Lan-DeMets
spending function of the information fraction ``t = n / n_max`` (O'Brien-Fleming by default,
Pocock beside it), and each look is judged at the alpha it spends (the increment of the
spending function). By the Bonferroni inequality over the looks the chance of any false
decision stays at or under ``alpha`` whatever the looks' correlation; the exact group-sequential
boundaries would be a little less strict.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["interval", "non_inferiority", "equivalence", "slopes", "page_p",
           "seeds_for_power", "seeds_for_non_inferiority", "seeds_for_equivalence",
           "SPENDING", "spent", "look_levels"]

#: Lan-DeMets alpha-spending functions by name.
SPENDING = ("obrien-fleming", "pocock")


def _check_level(name: str, value: float) -> None:
    if not 0.0 < float(value) < 1.0:
        raise ValueError(f"{name} must lie in (0, 1), got {value!r}")


def _as_values(values, name: str = "values") -> np.ndarray:
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or x.size < 1 or not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be a non-empty 1-d sequence of finite numbers, got "
                         f"{values!r}")
    return x


def interval(values, level: float = 0.95) -> tuple[float, float, float, float]:
    """``(mean, std, low, high)``: the mean, its sample std (ddof 1) and the two-sided Student-t
    interval at ``level`` (``low = high = mean`` for one value)."""
    from scipy.stats import t

    _check_level("level", level)
    x = _as_values(values)
    mean = float(x.mean())
    if x.size < 2:
        return mean, 0.0, mean, mean
    std = float(x.std(ddof=1))
    half = float(t.ppf(0.5 + level / 2, x.size - 1)) * std / math.sqrt(x.size)
    return mean, std, mean - half, mean + half


def non_inferiority(effect, margin: float, alpha: float = 0.05) -> dict:
    """One-sided t-test of ``H0: mean(effect) <= -margin``.

    Parameters
    ----------
    effect : sequence of float, shape (n,)
        Per-seed differences signed so that the paper's side is positive.
    margin : float
        > 0.
    alpha : float

    Returns
    -------
    dict
        ``p`` (the test's p-value), ``low``, ``high`` (the two-sided ``1 - 2 alpha`` interval
        of the mean), ``decided``: ``"non-inferior"`` (``p < alpha``), ``"inferior"`` (the
        interval lies below ``-margin``) or None.
    """
    from scipy.stats import t

    _check_level("alpha", alpha)
    if not margin > 0:
        raise ValueError(f"margin must be > 0, got {margin!r}")
    x = _as_values(effect, "effect")
    if x.size < 2:
        return {"p": None, "low": float(x[0]), "high": float(x[0]), "decided": None}
    mean, std, low, high = interval(x, 1 - 2 * alpha)
    if std == 0:
        p = 0.0 if mean > -margin else 1.0
    else:
        p = float(t.sf((mean + margin) / (std / math.sqrt(x.size)), x.size - 1))
    decided = "non-inferior" if p < alpha else ("inferior" if high < -margin else None)
    return {"p": p, "low": low, "high": high, "decided": decided}


def equivalence(effect, margin: float, alpha: float = 0.05) -> dict:
    """Two one-sided t-tests (TOST) of ``|mean(effect)| < margin``.

    Returns
    -------
    dict
        ``p`` (the larger of the two one-sided p-values), ``low``, ``high`` (the ``1 - 2 alpha``
        interval), ``decided``: ``"equivalent"`` (``p < alpha``), ``"different"`` (the interval
        lies wholly outside ``[-margin, margin]``) or None.
    """
    from scipy.stats import t

    _check_level("alpha", alpha)
    if not margin > 0:
        raise ValueError(f"margin must be > 0, got {margin!r}")
    x = _as_values(effect, "effect")
    if x.size < 2:
        return {"p": None, "low": float(x[0]), "high": float(x[0]), "decided": None}
    mean, std, low, high = interval(x, 1 - 2 * alpha)
    if std == 0:
        p = 0.0 if abs(mean) < margin else 1.0
    else:
        se, df = std / math.sqrt(x.size), x.size - 1
        p = float(max(t.sf((mean + margin) / se, df), t.cdf((mean - margin) / se, df)))
    outside = low > margin or high < -margin
    decided = "equivalent" if p < alpha else ("different" if outside else None)
    return {"p": p, "low": low, "high": high, "decided": decided}


def slopes(values, grid: Sequence[float]) -> np.ndarray:
    """Per-seed least-squares slope of ``values[s, :]`` against ``grid``.

    Parameters
    ----------
    values : array, shape (seeds, k)
    grid : sequence of float, length k >= 2, not all equal

    Returns
    -------
    numpy.ndarray, shape (seeds,)
    """
    y = np.asarray(values, dtype=float)
    x = np.asarray(grid, dtype=float)
    if y.ndim != 2 or x.ndim != 1 or y.shape[1] != x.size or x.size < 2 or np.ptp(x) == 0:
        raise ValueError(f"values must have shape (seeds, {x.size}) over a grid of >= 2 distinct "
                         f"points, got {y.shape} over {x.tolist()}")
    xc = x - x.mean()
    return (y - y.mean(axis=1, keepdims=True)) @ xc / float(xc @ xc)


def page_p(values, sign: int = 1) -> float | None:
    """Page's L test p-value for a trend over the grid in the direction ``sign`` (seeds are the
    blocks); None for fewer than 2 seeds or 3 grid points."""
    from scipy.stats import page_trend_test

    y = np.asarray(values, dtype=float)
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 3:
        return None
    ranks = list(range(1, y.shape[1] + 1))
    if sign < 0:
        ranks = ranks[::-1]
    return float(page_trend_test(y, predicted_ranks=ranks).pvalue)


def _smallest(achieved: Callable[[int], float], power: float, limit: int) -> int | None:
    lo, hi = 2, 2
    while achieved(hi) < power:
        lo, hi = hi, hi * 2
        if hi > limit:
            return None
    while lo < hi:  # power grows with n
        mid = (lo + hi) // 2
        if achieved(mid) >= power:
            hi = mid
        else:
            lo = mid + 1
    return hi


def _check(mean, std, power, alpha):
    for name, v in (("power", power), ("alpha", alpha)):
        _check_level(name, v)
    if not (math.isfinite(mean) and math.isfinite(std)) or std < 0:
        raise ValueError(f"mean and std must be finite with std >= 0, got {mean!r}, {std!r}")


def seeds_for_power(mean: float, std: float, power: float = 0.8, alpha: float = 0.05,
                    limit: int = 100_000) -> int | None:
    """Seeds a paired two-sided t-test at level ``alpha`` needs to detect ``mean`` at ``power``
    (noncentral t with ``n - 1`` degrees of freedom and noncentrality ``|mean| sqrt(n) / std``);
    None when the effect is 0 or ``limit`` seeds do not suffice."""
    from scipy.stats import nct, t

    _check(mean, std, power, alpha)
    if mean == 0:
        return None
    if std == 0:
        return 2

    def achieved(n: int) -> float:
        crit = t.ppf(1 - alpha / 2, n - 1)
        nc = abs(mean) * math.sqrt(n) / std
        return float(nct.sf(crit, n - 1, nc) + nct.cdf(-crit, n - 1, nc))

    return _smallest(achieved, power, limit)


def seeds_for_non_inferiority(effect: float, std: float, margin: float, power: float = 0.8,
                              alpha: float = 0.05, limit: int = 100_000) -> int | None:
    """Seeds the one-sided non-inferiority t-test needs for ``power`` when the true mean effect
    (paper's side positive) is ``effect``: noncentrality ``(effect + margin) sqrt(n) / std``;
    None when ``effect <= -margin`` (the claim is false there) or beyond ``limit``."""
    from scipy.stats import nct, t

    _check(effect, std, power, alpha)
    shift = effect + margin
    if shift <= 0:
        return None
    if std == 0:
        return 2

    def achieved(n: int) -> float:
        return float(nct.sf(t.ppf(1 - alpha, n - 1), n - 1, shift * math.sqrt(n) / std))

    return _smallest(achieved, power, limit)


def seeds_for_equivalence(effect: float, std: float, margin: float, power: float = 0.8,
                          alpha: float = 0.05, limit: int = 100_000) -> int | None:
    """Seeds TOST needs for ``power`` at a true mean ``effect``: the smallest ``n`` whose lower
    bound on the power, ``1 - P(T_lo <= c) - P(T_hi >= -c)`` (``T_lo``, ``T_hi`` noncentral t
    with noncentralities ``(effect +- margin) sqrt(n) / std``, ``c = t_{1 - alpha, n - 1}``),
    reaches ``power``; None when ``|effect| >= margin`` or beyond ``limit``. The bound drops the
    joint event, so the count errs high."""
    from scipy.stats import nct, t

    _check(effect, std, power, alpha)
    if abs(effect) >= margin:
        return None
    if std == 0:
        return 2

    def achieved(n: int) -> float:
        c, df, r = t.ppf(1 - alpha, n - 1), n - 1, math.sqrt(n) / std
        return float(1 - nct.cdf(c, df, (effect + margin) * r)
                     - nct.sf(-c, df, (effect - margin) * r))

    return _smallest(achieved, power, limit)


def spent(t: float, alpha: float = 0.05, spending: str = "obrien-fleming") -> float:
    """Alpha spent by information fraction ``t`` in ``(0, 1]`` (Lan and DeMets 1983).

    ``"obrien-fleming"``: ``2 (1 - Phi(z_{1 - alpha/2} / sqrt(t)))``; ``"pocock"``:
    ``alpha ln(1 + (e - 1) t)``. Both spend exactly ``alpha`` at ``t = 1``.
    """
    from scipy.stats import norm

    _check_level("alpha", alpha)
    if spending not in SPENDING:
        raise ValueError(f"spending must be one of {SPENDING}, got {spending!r}")
    if not 0.0 < float(t) <= 1.0:
        raise ValueError(f"t must lie in (0, 1], got {t!r}")
    if spending == "pocock":
        return float(alpha * math.log(1.0 + (math.e - 1.0) * t))
    return float(2.0 * norm.sf(norm.isf(alpha / 2) / math.sqrt(t)))


def look_levels(counts: Sequence[int], n_max: int, alpha: float = 0.05,
                spending: str = "obrien-fleming") -> list[tuple[float, float]]:
    """``(spent so far, level of this look)`` for looks at ``counts`` seeds of at most ``n_max``.

    Parameters
    ----------
    counts : sequence of int
        Seeds at each look, strictly increasing, the last at most ``n_max``.
    n_max : int
        The declared largest seed count.

    Returns
    -------
    list of (float, float)
        Per look: the cumulative alpha spent ``spent(n_k / n_max)`` and the look's level,
        ``spent(n_k / n_max) - spent(n_{k-1} / n_max)``.
    """
    c = [int(n) for n in counts]
    if not c or any(b <= a for a, b in zip(c, c[1:], strict=False)) or c[0] < 1 \
            or c[-1] > int(n_max):
        raise ValueError(f"counts must increase strictly from >= 1 up to n_max={n_max}, "
                         f"got {list(counts)}")
    out, before = [], 0.0
    for n in c:
        now = spent(n / n_max, alpha, spending)
        out.append((now, now - before))
        before = now
    return out
