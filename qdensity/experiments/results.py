"""Results of experiment runs: per-seed metrics, means with 95% confidence intervals, the
configuration and package versions, written as one JSON file that EXPERIMENTS.md can quote.

Confidence intervals over seeds use Student's t (:func:`mean_ci`); where the paper reports a
best-of-sweep or another statistic that is not a mean, :func:`bootstrap_ci` resamples it
(scipy's ``bootstrap``).

An interval never leaves its metric's range: :func:`metric_bounds` reads the range off the
metric's name (accuracies and probabilities in ``[0, 1]``, errors, counts and shots
non-negative, differences unbounded), and :func:`mean_ci` clips to it and says so
(``"clipped": true``). An interval from fewer than :data:`MIN_SEEDS` seeds carries
``"few_seeds": true``: with two seeds Student's t has one degree of freedom and its 95%
interval is twelve standard errors wide.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import platform
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from qdensity.validation import check_finite_array, check_seed

__all__ = [
    "mean_ci",
    "bootstrap_ci",
    "package_versions",
    "summarise",
    "metric_bounds",
    "runs_above",
    "MIN_SEEDS",
    "ExperimentResult",
    "RESULT_FORMAT",
]

#: Format version of the results JSON; :meth:`ExperimentResult.load` refuses other versions.
RESULT_FORMAT = 1

_PACKAGES = ("qdensity", "qiskit", "qiskit-aer", "numpy", "scipy", "scikit-learn", "torch",
             "optuna")


#: Fewest seeds whose interval is not flagged ``few_seeds``.
MIN_SEEDS = 3

# Name fragments -> range, checked in order (the first that matches wins): differences first,
# since "density_minus_base/test_accuracy" is a difference of accuracies.
_SIGNED = ("minus", "gap", "gain", "delta_acc", "difference", "diff", "advantage", "log",
           " - ")
_UNIT = ("accuracy", "success", "probability", "alpha", "fraction", "fidelity", "kept",
         "holds", "non_vacuous", "rate_above")
_NONNEGATIVE = ("mse", "shots", "circuits", "distance", "eps", "error", "bound", "seconds",
                "std", "rows", "parameters", "overhead", "count", "norm", "loss", "trials",
                "cost")


def metric_bounds(name: str) -> tuple[float, float]:
    """The range a metric's values can take, read off its name.

    Parameters
    ----------
    name : str
        Metric name as in a results file (``"density/test_accuracy"``, ``"pure/shots"``).

    Returns
    -------
    (low, high) : tuple of float
        ``(-inf, inf)`` for differences (``minus``, ``gap``, ``gain``) and unknown names,
        ``(0, 1)`` for accuracies, probabilities and mixture weights, ``(0, inf)`` for errors,
        MSEs, distances, counts and shots.

    Examples
    --------
    >>> metric_bounds("lcu/success_probability"), metric_bounds("lcu_minus_single")
    ((0.0, 1.0), (-inf, inf))
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    low = name.lower()
    if any(k in low for k in _SIGNED):
        return (-math.inf, math.inf)
    if any(k in low for k in _UNIT):
        return (0.0, 1.0)
    if any(k in low for k in _NONNEGATIVE):
        return (0.0, math.inf)
    return (-math.inf, math.inf)


def _finite_values(values, name: str) -> np.ndarray:
    arr = check_finite_array(values, name).ravel()
    if arr.size == 0:
        raise ValueError(f"{name} is empty: a confidence interval needs at least one value")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def _check_confidence(confidence) -> float:
    c = float(confidence)
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence!r}")
    return c


def mean_ci(values: Sequence[float] | np.ndarray, confidence: float = 0.95,
            bounds: tuple[float, float] | None = None) -> dict[str, float]:
    """Mean over seeds with a Student-t confidence interval, kept inside the metric's range.

    Parameters
    ----------
    values : sequence of float, length ``S >= 1``
        One value per seed.
    confidence : float
        Coverage of the interval, in ``(0, 1)``.
    bounds : (low, high), optional
        The metric's range (:func:`metric_bounds`); the interval is clipped to it and
        ``clipped`` says whether that happened. Values outside it are refused.

    Returns
    -------
    dict
        ``mean``, ``low``, ``high``, ``std`` (sample standard deviation, ``ddof=1``), ``sem``,
        ``n``, ``few_seeds`` (``n < MIN_SEEDS``) and, with ``bounds``, ``clipped``. With one
        seed the interval is the point itself and ``std`` is ``nan``: one run says nothing
        about the spread, and the JSON says so.

    Examples
    --------
    >>> ci = mean_ci([0.80, 0.82, 0.84])
    >>> round(ci["mean"], 3), round(ci["low"], 3), round(ci["high"], 3)
    (0.82, 0.77, 0.87)
    """
    arr = _finite_values(values, "values")
    c = _check_confidence(confidence)
    lo_b, hi_b = (-math.inf, math.inf) if bounds is None else _check_bounds(bounds)
    if arr.min() < lo_b or arr.max() > hi_b:
        raise ValueError(f"values {arr.tolist()} leave the metric's range bounds="
                         f"{(lo_b, hi_b)}")
    mean = float(arr.mean())
    few = bool(arr.size < MIN_SEEDS)
    if arr.size == 1:
        out = {"mean": mean, "low": mean, "high": mean, "std": math.nan, "sem": math.nan,
               "n": 1, "few_seeds": few}
    else:
        from scipy.stats import t

        std = float(arr.std(ddof=1))
        sem = std / math.sqrt(arr.size)
        half = float(t.ppf(0.5 + c / 2, arr.size - 1)) * sem
        out = {"mean": mean, "low": mean - half, "high": mean + half, "std": std, "sem": sem,
               "n": int(arr.size), "few_seeds": few}
    if bounds is not None:
        out["clipped"] = bool(out["low"] < lo_b or out["high"] > hi_b)
        out["low"], out["high"] = max(out["low"], lo_b), min(out["high"], hi_b)
    return out


def _check_bounds(bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise TypeError(f"bounds must be a pair (low, high) of numbers, got {bounds!r}") from None
    if not lo < hi:
        raise ValueError(f"bounds must have low < high, got {bounds!r}")
    return lo, hi


def bootstrap_ci(
    values: Sequence[float] | np.ndarray,
    statistic: Callable[[np.ndarray], float] = np.mean,
    confidence: float = 0.95,
    n_resamples: int = 2000,
    seed: int = 0,
) -> dict[str, float]:
    """Bootstrap (BCa, scipy) confidence interval of any statistic of per-run values.

    Parameters
    ----------
    values : sequence of float, length ``>= 2``
    statistic : callable
        Maps a 1-d array to a number (mean, median, a top-k mean, ...).
    confidence : float
        In ``(0, 1)``.
    n_resamples : int
        Bootstrap resamples.
    seed : int
        Seed of the resampling.

    Returns
    -------
    dict
        ``estimate`` (the statistic of ``values``), ``low``, ``high``, ``n``.

    Examples
    --------
    >>> ci = bootstrap_ci([0.1, 0.2, 0.3, 0.4, 0.5], np.median)
    >>> ci["estimate"], ci["low"] <= 0.3 <= ci["high"]
    (0.3, True)
    """
    check_seed(seed)
    arr = _finite_values(values, "values")
    if arr.size < 2:
        raise ValueError(f"values needs at least 2 entries for a bootstrap, got {arr.size}")
    c = _check_confidence(confidence)
    from scipy.stats import bootstrap

    est = float(statistic(arr))
    if np.ptp(arr) == 0.0:
        return {"estimate": est, "low": est, "high": est, "n": int(arr.size)}
    res = bootstrap((arr,), lambda a, axis=-1: np.apply_along_axis(statistic, axis, a),
                    confidence_level=c, n_resamples=int(n_resamples), method="BCa",
                    random_state=np.random.default_rng(seed))
    low, high = float(res.confidence_interval.low), float(res.confidence_interval.high)
    if not (np.isfinite(low) and np.isfinite(high)):  # BCa degenerate: fall back to percentile
        res = bootstrap((arr,), lambda a, axis=-1: np.apply_along_axis(statistic, axis, a),
                        confidence_level=c, n_resamples=int(n_resamples), method="percentile",
                        random_state=np.random.default_rng(seed))
        low, high = float(res.confidence_interval.low), float(res.confidence_interval.high)
    return {"estimate": est, "low": min(low, est), "high": max(high, est), "n": int(arr.size)}


def runs_above(values: Sequence[float] | np.ndarray, threshold: float = 0.8) -> dict:
    """The paper's sweep aggregation (hyperparameters appendix, Fig. 11b): of the runs of a
    sweep, those that reach ``threshold`` ("the best x/32 hyperparameter runs, those which
    achieve at least 80% accuracy"), their count and their mean.

    Parameters
    ----------
    values : sequence of float, length >= 1
        One final accuracy per sweep trial.
    threshold : float
        In ``[0, 1]``.

    Returns
    -------
    dict
        ``count`` (x), ``of`` (the number of trials), ``mean`` and ``std`` (ddof=1) of the runs
        at or above the threshold (None when fewer than one or two reach it).

    Examples
    --------
    >>> runs_above([0.9, 0.85, 0.4, 0.82])["count"]
    3
    """
    arr = _finite_values(values, "values")
    t = float(threshold)
    if not 0.0 <= t <= 1.0:
        raise ValueError(f"threshold must lie in [0, 1], got {threshold!r}")
    kept = arr[arr >= t]
    return {"count": int(kept.size), "of": int(arr.size),
            "mean": float(kept.mean()) if kept.size else None,
            "std": float(kept.std(ddof=1)) if kept.size > 1 else None}


def package_versions() -> dict[str, str | None]:
    """Versions of Python and of the packages a result depends on (``None`` if absent).

    qdensity itself is read from ``qdensity.__version__`` when it runs from a source tree that
    is not installed (on ``PYTHONPATH``).
    """
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    if out["qdensity"] is None:  # the parent package is always loaded before this module
        out["qdensity"] = getattr(sys.modules.get("qdensity"), "__version__", None)
    return out


def summarise(per_seed: Sequence[Mapping[str, Any]], confidence: float = 0.95) -> dict:
    """Mean and confidence interval of every scalar metric shared by all seeds.

    Parameters
    ----------
    per_seed : sequence of mappings
        One mapping of metric name -> value per seed; non-scalar entries (curves, lists) are
        left out of the summary.
    confidence : float

    Returns
    -------
    dict
        metric name -> :func:`mean_ci` of its values over seeds, clipped to the metric's range
        (:func:`metric_bounds`).

    Examples
    --------
    >>> s = summarise([{"acc": 0.8, "curve": [1, 2]}, {"acc": 0.9, "curve": [1, 3]}])
    >>> sorted(s), round(s["acc"]["mean"], 2)
    (['acc'], 0.85)
    """
    if not per_seed:
        raise ValueError("per_seed is empty: nothing to summarise")
    keys = [k for k, v in per_seed[0].items()
            if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)]
    out = {}
    for key in keys:
        vals = [row.get(key) for row in per_seed]
        if all(isinstance(v, (int, float, np.integer, np.floating)) for v in vals):
            lo, hi = metric_bounds(key)
            arr = np.asarray(vals, dtype=float)
            inside = np.all(np.isfinite(arr)) and arr.min() >= lo and arr.max() <= hi
            out[key] = mean_ci(arr, confidence, (lo, hi) if inside else None)
    return out


def _jsonable(obj):
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None  # JSON has no NaN; a missing spread reads as null
    return obj


@dataclass
class ExperimentResult:
    """One experiment run: what was run, with which seeds, what each seed gave, the summary.

    Attributes
    ----------
    name : str
        Experiment name (``qdensity experiment NAME``).
    mode : str
        ``"quick"`` or ``"full"`` (or a user label).
    config : dict
        Every setting the run used (sizes, epochs, learning rates, shot budgets).
    seeds : list of int
        One seed per run, in order.
    per_seed : list of dict
        Metrics of each seed (scalars and curves).
    summary : dict
        Scalar metric -> mean and confidence interval (:func:`summarise`).
    curves : dict
        Curve name -> point-by-point mean and confidence interval over seeds
        (:func:`qdensity.experiments.registry.curve_summary`).
    figures : list of str
        File names of the PNG figures written beside the JSON (names, not paths, so that the
        folder can move).
    seconds : float or None
        Wall time of the whole run.
    versions : dict
        :func:`package_versions` at the time of the run.
    created : str
        UTC time stamp (ISO 8601).
    """

    name: str
    mode: str
    config: dict
    seeds: list[int]
    per_seed: list[dict]
    summary: dict = field(default_factory=dict)
    curves: dict = field(default_factory=dict)
    figures: list[str] = field(default_factory=list)
    seconds: float | None = None
    versions: dict = field(default_factory=package_versions)
    created: str = field(
        default_factory=lambda: _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))

    def __post_init__(self) -> None:
        if len(self.seeds) != len(self.per_seed):
            raise ValueError(f"seeds has {len(self.seeds)} entries but per_seed "
                             f"{len(self.per_seed)}: one metrics row per seed")
        if not self.summary and self.per_seed:
            self.summary = summarise(self.per_seed)

    def to_dict(self) -> dict:
        """The JSON-ready content, with the format version."""
        return _jsonable({"format": RESULT_FORMAT, **asdict(self)})

    def save(self, directory: str | Path) -> Path:
        """Write ``<directory>/<name>-<mode>.json`` (the directory is created); return its path."""
        path = Path(directory)
        path.mkdir(parents=True, exist_ok=True)
        out = path / f"{self.name}-{self.mode}.json"
        out.write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")
        return out

    @classmethod
    def load(cls, path: str | Path) -> ExperimentResult:
        """Read a file written by :meth:`save`; refuses another format version."""
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"cannot read results file {str(path)!r}: {exc}") from exc
        if not isinstance(data, dict) or data.get("format") != RESULT_FORMAT:
            found = data.get("format") if isinstance(data, dict) else None
            raise ValueError(f"{str(path)!r} is not a qdensity results file of format "
                             f"{RESULT_FORMAT} (found format {found!r})")
        data.pop("format")
        return cls(**data)
