"""Verdicts by rule against scipy.stats' own tests, Monte Carlo power and textbook power tables; the
generated README / EXPERIMENTS.md sections against the committed files; merging results."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from qdensity_paper import _rule
from qdensity_paper.claims import CLAIMS
from qdensity_paper.merge import first_difference, merge_results
from qdensity_paper.results import ExperimentResult
from qdensity_paper.verdicts import (
    MARKERS,
    Claim,
    claims_for,
    report,
    seeds_for_power,
    splice,
    verdict,
)

ROOT = Path(__file__).resolve().parents[3]


def _result(diffs, mode="full", config=None, seeds=None):
    rows = [{"a": 0.5 + d, "b": 0.5} for d in diffs]
    return ExperimentResult(name="x", mode=mode, config=config or {}, per_seed=rows,
                            seeds=list(range(len(rows))) if seeds is None else seeds)


def _claim(kind="superiority", sign=1, **kw):
    return Claim("x/c", "claim", "line", kind, "a", "b", sign=sign, **kw)


@pytest.mark.parametrize("diffs, sign, expected", [
    ([0.10, 0.12, 0.09, 0.11, 0.13], 1, "reproduced"),
    ([0.10, 0.12, 0.09, 0.11, 0.13], -1, "not reproduced"),
    ([-0.10, -0.12, -0.09, -0.11, -0.13], -1, "reproduced"),
    ([0.05, -0.04, 0.10, -0.06, 0.02], 1, "inconclusive"),
])
def test_superiority(diffs, sign, expected):
    low, high = stats.t.interval(0.95, len(diffs) - 1, loc=np.mean(diffs),
                                 scale=stats.sem(diffs))
    v = verdict(_result(diffs), _claim(sign=sign))
    assert v["verdict"] == expected
    assert v["low"] == pytest.approx(low) and v["high"] == pytest.approx(high)
    if expected == "inconclusive":
        assert v["seeds_needed"] >= 6


@pytest.mark.parametrize("diffs, sign, expected", [
    ([-0.01, 0.00, 0.01, -0.02, 0.005], 1, "non-inferior"),  # level, well inside 0.05
    ([-0.20, -0.22, -0.19, -0.21, -0.18], 1, "not reproduced"),  # far below -0.05
    ([0.20, 0.22, 0.19, 0.21, 0.18], -1, "not reproduced"),  # "a lower is better", a higher
    ([-0.06, 0.04, -0.10, 0.03, -0.05], 1, "inconclusive"),
])
def test_non_inferiority_is_scipys_one_sided_test(diffs, sign, expected):
    v = verdict(_result(diffs), _claim("non-inferiority", sign, margins=(0.05, 0.02)))
    effect = sign * np.asarray(diffs)
    p = stats.ttest_1samp(effect + 0.05, 0.0, alternative="greater").pvalue
    assert v["verdict"] == expected and v["p"] == pytest.approx(p)
    low, high = stats.t.interval(0.90, len(diffs) - 1, loc=np.mean(diffs),
                                 scale=stats.sem(diffs))
    assert v["low"] == pytest.approx(low) and v["high"] == pytest.approx(high)
    assert v["second"].endswith("at margin 0.02")


@pytest.mark.parametrize("diffs, expected", [
    ([-0.01, 0.00, 0.01, -0.02, 0.005], "equivalent"),
    ([0.20, 0.22, 0.19, 0.21, 0.18], "not reproduced"),
    ([0.02, 0.09, -0.01, 0.07, 0.05], "inconclusive"),
])
def test_equivalence_is_two_one_sided_scipy_tests(diffs, expected):
    v = verdict(_result(diffs), _claim("equivalence", margins=(0.05, 0.02)))
    d = np.asarray(diffs)
    p = max(stats.ttest_1samp(d + 0.05, 0.0, alternative="greater").pvalue,
            stats.ttest_1samp(d - 0.05, 0.0, alternative="less").pvalue)
    assert v["verdict"] == expected and v["p"] == pytest.approx(p)


def test_equivalence_to_a_reported_number():
    rows = [{"a": v} for v in (12.0, 19.0, 8.0)]
    claim = Claim("x/c", "30/32", "line", "equivalence", "a", reference=30.0, margins=(3, 1.5))
    v = verdict(ExperimentResult("x", "paper", {}, [0, 1, 2], rows), claim)
    assert v["verdict"] == "not reproduced" and v["mean"] == pytest.approx(13.0 - 30.0)


def test_trend_is_a_slope_test_with_pages_test_beside_it():
    rng = np.random.default_rng(1)
    grid = (1, 2, 3, 4, 9)
    values = 0.5 + 0.02 * np.array(grid) + rng.normal(0, 0.01, (6, 5))
    rows = [{f"D{d}": float(v) for d, v in zip(grid, row, strict=True)} for row in values]
    claim = Claim("x/t", "rises", "line", "trend", series=tuple((d, f"D{d}") for d in grid))
    v = verdict(ExperimentResult("x", "paper", {}, list(range(6)), rows), claim)
    slopes = [np.polyfit(grid, row, 1)[0] for row in values]
    low, high = stats.t.interval(0.95, 5, loc=np.mean(slopes), scale=stats.sem(slopes))
    assert v["verdict"] == "reproduced" and v["mean"] == pytest.approx(np.mean(slopes))
    assert v["low"] == pytest.approx(low) and v["high"] == pytest.approx(high)
    assert v["page_p"] < 0.01
    down = Claim("x/t", "falls", "line", "trend", sign=-1, series=claim.series)
    assert verdict(ExperimentResult("x", "paper", {}, list(range(6)), rows),
                   down)["verdict"] == "not reproduced"


def test_bound_holds_in_every_seed_or_not_at_all():
    rows = [{"a": 0.3, "b": 0.1}, {"a": 0.2, "b": 0.19}, {"a": 0.9, "b": 0.1}]
    claim = Claim("x/b", "bound", "line", "bound", "a", "b")
    v = verdict(ExperimentResult("x", "paper", {}, [0, 1, 2], rows), claim)
    assert v["verdict"] == "reproduced" and v["smallest"] == pytest.approx(0.01)
    rows[1]["b"] = 0.25
    v = verdict(ExperimentResult("x", "paper", {}, [0, 1, 2], rows), claim)
    assert v["verdict"] == "not reproduced" and v["smallest"] == pytest.approx(-0.05)
    exact = Claim("x/e", "180", "line", "exact", "a", reference=0.3)
    assert verdict(ExperimentResult("x", "paper", {}, [0], rows[:1]), exact)["verdict"] == (
        "reproduced")


def test_missing_metrics_and_one_seed():
    missing = verdict(_result([0.1, 0.2]), Claim("x/c", "c", "l", "superiority", "a", "zzz"))
    assert missing["verdict"] == "not comparable" and "zzz" in missing["reason"]
    one = verdict(_result([0.1]), _claim())
    assert one["verdict"] == "inconclusive" and one["seeds_needed"] is None


def test_not_comparable_follows_from_the_departures_that_touch_the_claim():
    """pyramid-shots at the paper's settings: the data departure touches the x/32 counts, not
    the comparisons; a --full run is a reduced protocol; a --quick run is not judged."""
    from qdensity_paper.registry import get_experiment

    settings = dict(get_experiment("pyramid-shots").protocol.settings)
    row = {f"{m}/{k}": 0.8 for m in ("pure", "odd_even", "compressed")
           for k in ("test_accuracy", "runs_above", "runs_above_mean")}
    rows = [{**row, "pure/test_accuracy_at_density_budget": 0.7 + 0.01 * i} for i in range(3)]
    paper = ExperimentResult("pyramid-shots", "paper", settings, [0, 1, 2], rows)
    by_key = {v["key"]: v for v in map(lambda c: verdict(paper, c), claims_for(paper))}
    assert by_key["pyramid-shots/count-pure"]["verdict"] == "not comparable"
    assert "80%" in by_key["pyramid-shots/count-pure"]["reason"]
    assert by_key["pyramid-shots/budget"]["verdict"] == "reproduced"
    assert by_key["pyramid-shots/odd-even"]["verdict"] == "non-inferior"
    full = ExperimentResult("pyramid-shots", "full", {**settings, "epochs": 30}, [0, 1, 2], rows)
    assert {verdict(full, c)["verdict"] for c in claims_for(full)} == {"not comparable"}
    assert "epochs=30" in verdict(full, claims_for(full)[0])["reason"]
    assert claims_for(ExperimentResult("pyramid-shots", "quick", settings, [0], rows[:1])) == []


def test_lcu_without_its_sweep_is_not_the_papers_model():
    from qdensity_paper.registry import get_experiment

    settings = dict(get_experiment("lcu-vs-single").protocol.settings)
    rows = [{"lcu/minus_single": 0.1 + 0.01 * i} for i in range(3)]
    swept = ExperimentResult("lcu-vs-single", "paper", settings, [0, 1, 2], rows)
    fixed = ExperimentResult("lcu-vs-single", "paper", {**settings, "trials": 0}, [0, 1, 2], rows)
    [claim] = claims_for(swept)
    assert verdict(swept, claim)["verdict"] == "reproduced"
    assert "no optuna sweep" in verdict(fixed, claim)["reason"]


def test_the_claims_table():
    """Keys unique, every departure names claims that exist, every experiment with a paper
    protocol has claims, and every non-inferiority / equivalence claim states why its margins."""
    from qdensity_paper.registry import EXPERIMENTS, get_experiment

    keys = [c.key for c in CLAIMS]
    assert len(keys) == len(set(keys))
    for name in EXPERIMENTS:
        protocol = get_experiment(name).protocol
        if protocol is None:
            continue
        assert any(c.experiment == name for c in CLAIMS), name
        for d in protocol.departures:
            assert all(k == "*" or k in keys for k in d.touches), (name, d.touches)
    for c in CLAIMS:
        assert c.line and (c.margin_reason or c.kind not in ("non-inferiority", "equivalence"))
    with pytest.raises(ValueError, match="two positive margins"):
        Claim("x/c", "c", "l", "non-inferiority", "a", "b", margins=(0.05,))
    with pytest.raises(ValueError, match="kind"):
        Claim("x/c", "c", "l", "better", "a", "b")


def test_seeds_for_power_matches_power_tables():
    # paired t-test, two-sided 0.05, power 0.8 (Cohen's tables / G*Power):
    # effect size 0.5 -> 34 pairs, 0.8 -> 15, 1.0 -> 10
    assert seeds_for_power(0.5, 1.0) == 34
    assert seeds_for_power(0.8, 1.0) == 15
    assert seeds_for_power(-1.0, 1.0) == 10
    assert seeds_for_power(0.0, 1.0) is None
    with pytest.raises(ValueError, match="power"):
        seeds_for_power(0.5, 1.0, power=1.5)


def _simulated_power(test, n, mean, std, margin, draws=20_000, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.normal(mean, std, (draws, n))
    m, se = x.mean(axis=1), x.std(axis=1, ddof=1) / math.sqrt(n)
    c = stats.t.ppf(0.95, n - 1)
    lower = (m + margin) / se > c
    return float(np.mean(lower if test == "ni" else lower & ((m - margin) / se < -c)))


@pytest.mark.parametrize("test, mean", [("ni", -0.01), ("ni", 0.0), ("eq", 0.0), ("eq", 0.01)])
def test_seed_counts_of_the_one_sided_tests_reach_their_power(test, mean):
    """Monte Carlo of the test itself (20,000 draws, standard error <= 0.003): at the count the
    power reaches 0.8 (less 4 standard errors: a false failure about 3e-5); for
    non-inferiority, one seed fewer falls short (the count is the smallest)."""
    std, margin = 0.03, 0.05
    count = (_rule.seeds_for_non_inferiority if test == "ni" else _rule.seeds_for_equivalence)
    n = count(mean, std, margin)
    assert n is not None and n >= 2
    assert _simulated_power(test, n, mean, std, margin) >= 0.8 - 0.012
    if test == "ni" and n > 2:
        assert _simulated_power(test, n - 1, mean, std, margin, seed=1) < 0.8 + 0.012
    assert count(-margin - 0.01 if test == "ni" else margin, std, margin) is None


def test_generated_sections_are_current():
    generated = report(ROOT / "results")
    for name, text in generated.items():
        current = (ROOT / name).read_text(encoding="utf-8")
        assert splice(current, text, name) == current, (
            f"{name} drifted from results/: run `qdensity results report --write`")


def test_splice_needs_markers():
    begin, end = MARKERS
    assert splice(f"a\n{begin}\nold\n{end}\nb", "new") == f"a\n{begin}\nnew\n{end}\nb"
    with pytest.raises(ValueError, match="no generated section"):
        splice("nothing here", "new", "README.md")


def test_merge_recomputes_the_summary_and_checks_its_inputs():
    rng = np.random.default_rng(0)
    vals = rng.uniform(0.6, 0.9, 6)
    rows = [{"acc": float(v), "curves": {"c": {"x": [1, 2], "y": [float(v), float(v) / 2],
                                               "x_label": "e", "y_label": "test accuracy"}}}
            for v in vals]
    a = ExperimentResult("x", "full", {"k": 1}, [0, 1, 2], rows[:3])
    b = ExperimentResult("x", "full", {"k": 1}, [3, 4, 5, 2], rows[3:] + rows[2:3])
    m = merge_results([b, a])
    assert m.seeds == list(range(6))
    half = 2.5705818366147395 * vals.std(ddof=1) / math.sqrt(6)  # t_{0.975, 5}
    assert m.summary["acc"]["mean"] == pytest.approx(vals.mean())
    assert m.summary["acc"]["high"] == pytest.approx(min(vals.mean() + half, 1.0))
    assert m.curves["c"]["mean"][0] == pytest.approx(vals.mean())
    with pytest.raises(ValueError, match=r"config.k"):
        merge_results([a, ExperimentResult("x", "full", {"k": 2}, [7], rows[:1])])
    with pytest.raises(ValueError, match="mode"):
        merge_results([a, ExperimentResult("x", "paper", {"k": 1}, [7], rows[:1])])
    with pytest.raises(ValueError, match="seed 0 is in two runs"):
        merge_results([a, ExperimentResult("x", "full", {"k": 1}, [0], rows[4:5])])
    with pytest.raises(ValueError, match="empty"):
        merge_results([])
    assert first_difference({"a": [1, {"b": 2}]}, {"a": [1, {"b": 3}]}) == "a[1].b"


def test_results_cli(tmp_path, capsys):
    from qdensity.cli.main import main

    rows = [{"acc": v} for v in (0.7, 0.8, 0.75, 0.72)]
    ExperimentResult("x", "full", {"k": 1}, [0, 1], rows[:2]).save(tmp_path / "a")
    ExperimentResult("x", "full", {"k": 1}, [2, 3], rows[2:]).save(tmp_path / "b")
    out = tmp_path / "c.json"
    assert main(["results", "merge", str(tmp_path / "a" / "x-full.json"),
                 str(tmp_path / "b" / "x-full.json"), "-o", str(out)]) == 0
    assert json.loads(out.read_text())["seeds"] == [0, 1, 2, 3]
    capsys.readouterr()
    assert main(["results", "show", str(out), "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["summary"]["acc"]["mean"] == pytest.approx(0.7425)
    assert main(["results", "show", str(tmp_path / "a" / "x-full.json")]) == 0
    assert "few seeds" in capsys.readouterr().out
    assert main(["results", "--json", "show", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["seeds"] == [0, 1, 2, 3]
    assert main(["results"]) == 2
    assert "name a sub-command" in capsys.readouterr().err
    ExperimentResult("x", "full", {"k": 2}, [5], rows[:1]).save(tmp_path / "d")
    assert main(["results", "merge", str(out), str(tmp_path / "d" / "x-full.json"),
                 "-o", str(tmp_path / "e.json")]) == 2
    assert "config.k" in capsys.readouterr().err
