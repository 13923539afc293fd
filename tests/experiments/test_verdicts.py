"""Verdicts by rule against hand-computed Student-t intervals and textbook power tables; the
generated README / EXPERIMENTS.md sections against the committed files; merging results."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from qdensity.experiments.merge import first_difference, merge_results
from qdensity.experiments.results import ExperimentResult
from qdensity.experiments.verdicts import (
    MARKERS,
    Claim,
    claims_for,
    report,
    seeds_for_power,
    splice,
    verdict,
)

ROOT = Path(__file__).resolve().parents[2]
T4 = 2.7764451051977987  # t_{0.975, 4}


def _result(diffs, mode="full", config=None, seeds=None):
    rows = [{"a": 0.5 + d, "b": 0.5} for d in diffs]
    return ExperimentResult(name="x", mode=mode, config=config or {}, per_seed=rows,
                            seeds=list(range(len(rows))) if seeds is None else seeds)


def _half(diffs):
    d = np.asarray(diffs)
    return T4 * d.std(ddof=1) / math.sqrt(d.size)


@pytest.mark.parametrize("diffs, sign, expected", [
    ([0.10, 0.12, 0.09, 0.11, 0.13], 1, "reproduced"),
    ([0.10, 0.12, 0.09, 0.11, 0.13], -1, "not reproduced"),
    ([-0.10, -0.12, -0.09, -0.11, -0.13], -1, "reproduced"),
    ([0.05, -0.04, 0.10, -0.06, 0.02], 1, "inconclusive"),
])
def test_rule(diffs, sign, expected):
    mean, half = np.mean(diffs), _half(diffs)
    v = verdict(_result(diffs), Claim("x", "claim", "a", "b", sign=sign))
    assert v["verdict"] == expected
    assert v["low"] == pytest.approx(mean - half) and v["high"] == pytest.approx(mean + half)
    if expected == "inconclusive":
        assert v["seeds_needed"] >= 6


def test_not_comparable_and_missing_metrics():
    claim = Claim("x", "c", "a", "b", comparable=lambda r: "steps" if r.mode == "full" else None)
    assert verdict(_result([0.1, 0.2, 0.3]), claim)["reason"] == "steps"
    assert verdict(_result([0.1, 0.11, 0.12], mode="paper"), claim)["verdict"] == "reproduced"
    missing = verdict(_result([0.1, 0.2]), Claim("x", "c", "a", "zzz"))
    assert missing["verdict"] == "not comparable" and "zzz" in missing["reason"]
    one = verdict(_result([0.1]), Claim("x", "c", "a", "b"))
    assert one["verdict"] == "inconclusive" and one["seeds_needed"] is None


def test_moe_runs_before_the_shared_sweep_are_not_comparable():
    """A moe file without the loader's input-gradient count predates the shared sweep loop
    (random search, old shot count): both claims not comparable, saying why; a newer one is
    judged."""
    rows = [{f"odd_even/{v}/{k}": 0.5 + 0.01 * i * (v == "moe")
             for v in ("moe", "density") for k in ("mean_accuracy", "std_accuracy")}
            for i in range(3)]
    old = ExperimentResult("moe", "full", {"decompositions": ["odd_even"], "trials": 8},
                           [0, 1, 2], rows)
    for row in evaluate_result(old):
        assert row["verdict"] == "not comparable"
        assert "random search" in row["reason"] and "input gradients" in row["reason"]
    new = ExperimentResult("moe", "full", {"decompositions": ["odd_even"], "trials": 8},
                           [0, 1, 2], [{**r, "odd_even/moe/circuits/input_gradients": 28}
                                       for r in rows])
    assert all(r["verdict"] != "not comparable" for r in evaluate_result(new))


def test_lcu_baseline_caveat_only_without_the_sweep():
    """lcu-vs-single with fixed learning rates carries the weak-baseline caveat; with each model
    tuned by its own study (trials > 0) it does not."""
    rows = [{"lcu/minus_single": 0.1 + 0.01 * i} for i in range(3)]
    fixed = ExperimentResult("lcu-vs-single", "full", {"trials": 0}, [0, 1, 2], rows)
    swept = ExperimentResult("lcu-vs-single", "paper", {"trials": 32}, [0, 1, 2], rows)
    old = ExperimentResult("lcu-vs-single", "full", {}, [0, 1, 2], rows)  # before the setting
    assert [c.caveat.split(":")[0] for c in claims_for(fixed)] == ["a weak baseline"]
    assert [c.caveat.split(":")[0] for c in claims_for(old)] == ["a weak baseline"]
    [claim] = claims_for(swept)
    assert claim.caveat == "" and claim.quantity == "lcu/minus_single"
    assert verdict(swept, claim)["verdict"] == "reproduced"


def evaluate_result(result):
    return [verdict(result, c) for c in claims_for(result)]


def test_seeds_for_power_matches_power_tables():
    # paired t-test, two-sided 0.05, power 0.8 (Cohen's tables / G*Power):
    # effect size 0.5 -> 34 pairs, 0.8 -> 15, 1.0 -> 10
    assert seeds_for_power(0.5, 1.0) == 34
    assert seeds_for_power(0.8, 1.0) == 15
    assert seeds_for_power(-1.0, 1.0) == 10
    assert seeds_for_power(0.0, 1.0) is None
    with pytest.raises(ValueError, match="power"):
        seeds_for_power(0.5, 1.0, power=1.5)


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
