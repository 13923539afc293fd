"""Experiment results: confidence intervals against their textbook formulas and coverage over
many simulated experiments, and the JSON round trip."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from qdensity_paper.results import (
    RESULT_FORMAT,
    ExperimentResult,
    bootstrap_ci,
    mean_ci,
    summarise,
)


def test_mean_ci_matches_the_t_formula():
    vals = [0.71, 0.74, 0.69, 0.78, 0.73]
    ci = mean_ci(vals)
    m, s = np.mean(vals), np.std(vals, ddof=1)
    half = 2.7764451051977987 * s / math.sqrt(5)  # t_{0.975, 4}
    assert ci["mean"] == pytest.approx(m)
    assert ci["low"] == pytest.approx(m - half) and ci["high"] == pytest.approx(m + half)
    one = mean_ci([0.5])
    assert one["low"] == one["high"] == 0.5 and math.isnan(one["std"])


def test_mean_ci_covers_the_true_mean_at_its_level():
    rng = np.random.default_rng(3)
    trials = 2000
    hits = 0
    for _ in range(trials):
        ci = mean_ci(rng.normal(1.0, 2.0, 5))
        hits += ci["low"] <= 1.0 <= ci["high"]
    # binomial(2000, 0.95): standard error 0.0049
    assert abs(hits / trials - 0.95) < 4 * math.sqrt(0.95 * 0.05 / trials)


def test_bootstrap_ci_contains_estimate_and_narrows_with_data():
    rng = np.random.default_rng(0)
    small = bootstrap_ci(rng.normal(size=10), np.median, seed=1)
    large = bootstrap_ci(rng.normal(size=400), np.median, seed=1)
    for ci in (small, large):
        assert ci["low"] <= ci["estimate"] <= ci["high"]
    assert (large["high"] - large["low"]) < (small["high"] - small["low"])
    const = bootstrap_ci([0.5, 0.5, 0.5])
    assert const["low"] == const["high"] == 0.5


def test_summary_and_json_round_trip(tmp_path):
    per_seed = [{"test_accuracy": 0.8, "shots": 1000, "curve": [0.1, 0.5]},
                {"test_accuracy": 0.9, "shots": 1000, "curve": [0.2, 0.6]}]
    res = ExperimentResult("toy", "quick", {"epochs": 2}, [0, 1], per_seed)
    assert set(res.summary) == {"test_accuracy", "shots"}
    s = res.summary["test_accuracy"]
    assert s["low"] <= s["mean"] <= s["high"] and s["mean"] == pytest.approx(0.85)
    path = res.save(tmp_path / "out")
    data = json.loads(path.read_text())
    assert data["format"] == RESULT_FORMAT and data["seeds"] == [0, 1]
    assert data["versions"]["qiskit"] and data["per_seed"][1]["curve"] == [0.2, 0.6]
    back = ExperimentResult.load(path)
    assert back.summary == res.to_dict()["summary"] and back.config == {"epochs": 2}


def test_bad_input():
    with pytest.raises(ValueError, match="values is empty"):
        mean_ci([])
    with pytest.raises(ValueError, match="finite"):
        mean_ci([1.0, float("nan")])
    with pytest.raises(ValueError, match="confidence"):
        mean_ci([1.0, 2.0], confidence=1.5)
    with pytest.raises(ValueError, match="at least 2"):
        bootstrap_ci([1.0])
    with pytest.raises(ValueError, match="one metrics row per seed"):
        ExperimentResult("toy", "quick", {}, [0, 1], [{"a": 1.0}])
    with pytest.raises(ValueError, match="per_seed is empty"):
        summarise([])


def test_load_refuses_other_formats(tmp_path):
    path = tmp_path / "old.json"
    path.write_text(json.dumps({"format": 99, "name": "x"}))
    with pytest.raises(ValueError, match="format 99"):
        ExperimentResult.load(path)
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(ValueError, match="junk.json"):
        ExperimentResult.load(tmp_path / "junk.json")


def test_intervals_stay_inside_the_metrics_range_and_say_so():
    # two seeds of a success probability: t_{0.975,1} = 12.706 gives [0.61 -/+ 1.14]
    raw = mean_ci([0.2, 1.0])
    assert raw["low"] < 0 and raw["high"] > 1 and raw["few_seeds"]
    ci = summarise([{"lcu/success_probability": 0.2}, {"lcu/success_probability": 1.0}])
    ci = ci["lcu/success_probability"]
    assert (ci["low"], ci["high"]) == (0.0, 1.0) and ci["clipped"] and ci["few_seeds"]
    assert ci["mean"] == pytest.approx(0.6)
    # a difference is not clipped, and three seeds are not flagged
    diff = summarise([{"lcu_minus_single": v} for v in (-0.1, 0.5, 0.9)])["lcu_minus_single"]
    assert not diff["clipped"] and not diff["few_seeds"]
    assert diff["low"] == pytest.approx(0.4333333 - 4.302653 * np.std([-0.1, .5, .9], ddof=1)
                                        / math.sqrt(3), rel=1e-5)
    with pytest.raises(ValueError, match="range"):
        mean_ci([0.5, 1.5], bounds=(0.0, 1.0))
    with pytest.raises(ValueError, match="low < high"):
        mean_ci([0.5, 0.6], bounds=(1.0, 0.0))


def test_metric_bounds_by_name():
    from qdensity_paper.results import metric_bounds

    assert metric_bounds("D1/test_accuracy") == (0.0, 1.0)
    assert metric_bounds("supp_j/L50/vanilla/test_mse") == (0.0, math.inf)
    assert metric_bounds("xx/density_minus_base") == (-math.inf, math.inf)
    assert metric_bounds("supp_j/L50/density/gap") == (-math.inf, math.inf)
    with pytest.raises(TypeError, match="name"):
        metric_bounds(3)


def test_runs_above_is_the_papers_sweep_aggregation():
    from qdensity_paper.results import runs_above

    accs = [0.91, 0.79, 0.80, 0.55, 0.86]
    out = runs_above(accs, 0.8)
    assert (out["count"], out["of"]) == (3, 5)
    assert out["mean"] == pytest.approx((0.91 + 0.80 + 0.86) / 3)
    assert out["std"] == pytest.approx(np.std([0.91, 0.80, 0.86], ddof=1))
    none = runs_above([0.1, 0.2], 0.8)
    assert none["count"] == 0 and none["mean"] is None
    with pytest.raises(ValueError, match="threshold"):
        runs_above(accs, 80)


def test_metric_bounds_of_axis_labels():
    from qdensity_paper.results import metric_bounds

    assert metric_bounds("test MSE - train MSE") == (-math.inf, math.inf)
    assert metric_bounds("test accuracy") == (0.0, 1.0)
    assert metric_bounds("test MSE") == (0.0, math.inf)
