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
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from qdensity.io import atomic_write_text
from qdensity.validation import check_finite_array, check_seed
from qdensity_paper._result_files import (
    canonical,
    check_fields,
    locked,
    read_fields,
    recomputed,
)
from qdensity_paper._result_files import jsonable as _jsonable
from qdensity_paper._units import settings_hash

__all__ = [
    "mean_ci",
    "bootstrap_ci",
    "package_versions",
    "summarise",
    "curve_summary",
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


def curve_summary(per_seed: Sequence[Mapping], confidence: float = 0.95) -> dict:
    """Point-by-point mean and confidence interval of every curve shared by all seeds.

    Parameters
    ----------
    per_seed : sequence of dict
        Seeds' metrics; curves under ``"curves"``.
    confidence : float

    Returns
    -------
    dict
        curve name -> ``{"x", "mean", "low", "high", "x_label", "y_label"}``, lists of the
        length of the shortest seed's curve; ``x`` is the mean over seeds of the seeds' x
        values (equal for epochs and fixed shot schedules).
    """
    names = set.intersection(*(set(r.get("curves", {})) for r in per_seed)) if per_seed else set()
    out = {}
    for name in sorted(names):
        curves = [r["curves"][name] for r in per_seed]
        length = min(len(c["y"]) for c in curves)
        if length == 0:
            continue
        xs = np.array([c["x"][:length] for c in curves], dtype=float)
        ys = np.array([c["y"][:length] for c in curves], dtype=float)
        cis = [mean_ci(ys[:, i], confidence) for i in range(length)]
        out[name] = {"x": xs.mean(axis=0).tolist(), "mean": [c["mean"] for c in cis],
                     "low": [c["low"] for c in cis], "high": [c["high"] for c in cis],
                     "x_label": curves[0].get("x_label", "x"),
                     "y_label": curves[0].get("y_label", "y")}
    return out


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
    looks : list of list of int
        The seed sets the run's claims were judged at, in order (each holding the one
        before); a merge that adds seeds adds a look. Empty: one look, at all the seeds.
    per_seed : list of dict
        Metrics of each seed (scalars and curves).
    summary : dict
        Scalar metric -> mean and confidence interval (:func:`summarise`).
    curves : dict
        Curve name -> point-by-point mean and confidence interval over seeds
        (:func:`qdensity_paper.registry.curve_summary`).
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
    looks: list[list[int]] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    curves: dict = field(default_factory=dict)
    figures: list[str] = field(default_factory=list)
    seconds: float | None = None
    versions: dict = field(default_factory=package_versions)
    created: str = field(
        default_factory=lambda: _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    #: The file :meth:`save` last wrote this run into (None until saved).
    saved_to: ClassVar[Path | None] = None

    def __post_init__(self) -> None:
        check_fields(self.__dict__, "ExperimentResult")
        if len(self.seeds) != len(self.per_seed):
            raise ValueError(f"seeds has {len(self.seeds)} entries but per_seed "
                             f"{len(self.per_seed)}: one metrics row per seed")
        looks = [[int(s) for s in look] for look in self.looks]
        if any(not set(a) < set(b) for a, b in zip(looks, looks[1:], strict=False)) or any(
                not set(look) <= set(map(int, self.seeds)) for look in looks):
            raise ValueError(f"looks must be growing sets of this run's seeds, each holding the "
                             f"one before, got {self.looks!r} for seeds {self.seeds!r}")
        if not self.summary and self.per_seed:
            self.summary = summarise(self.per_seed)

    def to_dict(self) -> dict:
        """The JSON-ready content, with the format version."""
        return _jsonable({"format": RESULT_FORMAT, **asdict(self)})

    def save(self, directory: str | Path) -> Path:
        """Write this run into ``directory`` (created); return the file that holds its seeds.

        ``<name>-<mode>.json``, merged with the run of the same settings it may hold (seeds of
        both, this run's row for a seed in both; summary and curves recomputed); when it holds
        other settings (or no results file), ``<name>-<mode>-<settings hash>.json``, merged
        the same way. Under a lock shared by the runs writing the folder; replaced atomically
        (a temporary file renamed over it), so a full disk leaves the old file whole.
        """
        check_fields(self.__dict__, "ExperimentResult")  # a name changed since: never a path
        folder = Path(directory)
        folder.mkdir(parents=True, exist_ok=True)
        plain = folder / f"{self.name}-{self.mode}.json"
        named = folder / f"{self.name}-{self.mode}-{settings_hash(self.config)}.json"
        with locked(plain):
            target, earlier = plain, self._same_run(plain)
            if earlier is None and plain.exists():
                target, earlier = named, self._same_run(named)
            merged = self if earlier in (None, False) else self._merged_with(earlier)
            atomic_write_text(target, json.dumps(merged.to_dict(), indent=2) + "\n")
        # an instance note kept out of the dataclass fields (declared as a ClassVar default)
        self.saved_to = target  # type: ignore[misc]
        return target

    def _same_run(self, path: Path):
        """``path``'s result if it ran these settings; False: no file; None: anything else."""
        if not path.exists():
            return False
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                other = ExperimentResult.load(path)
        except (TypeError, ValueError):
            return None
        mine = json.loads(json.dumps(self.to_dict()))
        if (other.name, other.mode) != (self.name, self.mode) \
                or canonical(mine["config"]) != canonical(other.config):
            return None
        return other

    def _merged_with(self, earlier: ExperimentResult) -> ExperimentResult:
        rows = dict(zip(earlier.seeds, earlier.per_seed, strict=True))
        rows.update(zip(self.seeds, self.per_seed, strict=True))
        seeds = sorted(rows)
        per_seed = [rows[s] for s in seeds]
        kept = set(earlier.seeds) - set(self.seeds)
        seconds = self.seconds
        if kept and earlier.seconds is not None and seconds is not None:
            seconds = seconds + earlier.seconds
        figures = list(dict.fromkeys([*self.figures, *earlier.figures]))
        looks = ([list(look) for look in earlier.looks]
                 or [sorted(earlier.seeds)][:len(earlier.seeds)])
        if not looks or set(seeds) != set(looks[-1]):
            looks.append(seeds)
        return ExperimentResult(name=self.name, mode=self.mode, config=dict(self.config),
                                seeds=seeds, per_seed=per_seed, looks=looks,
                                summary=summarise(per_seed),
                                curves=curve_summary(per_seed), figures=figures,
                                seconds=seconds, versions=dict(self.versions),
                                created=self.created)

    @classmethod
    def load(cls, path: str | Path) -> ExperimentResult:
        """Read a file written by :meth:`save`; refuses another format version or fields of
        the wrong type (seeds must be non-negative ints).

        The summary and the curves are recomputed from the per-seed rows; where the stored
        ones disagree (a file edited by hand, or written by code that summarised
        differently) a warning names the file and the recomputed ones are used.
        """
        where = f"results file {str(path)!r}"
        data = read_fields(Path(path), RESULT_FORMAT, set(cls.__dataclass_fields__), where)
        data.update(recomputed(data, where, summarise, curve_summary, mean_ci))
        return cls(**data)
