"""The sequential looks, the claim categories, composite and monotone claims and the paper's words.

Oracles: the Lan-DeMets spending functions written out with scipy's normal quantiles; a Monte
Carlo of the two-look design itself (its false "reproduced" rate against the nominal 2.5%);
scipy's Student-t intervals for each step of a monotone claim; the paper's own sentences (a
fixture of the quoted sentences, LaTeX read as text) for every `paper` claim's quote.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from qdensity_paper import _rule
from qdensity_paper.claims import CLAIMS, Claim, counted
from qdensity_paper.results import ExperimentResult
from qdensity_paper.verdicts import headline, looks_of, verdict

HERE = Path(__file__).resolve().parent


def test_spending_functions_are_lan_demets():
    z = stats.norm.ppf(1 - 0.025)
    for t in (0.2, 0.6, 1.0):
        assert _rule.spent(t) == pytest.approx(2 * (1 - stats.norm.cdf(z / math.sqrt(t))))
        assert _rule.spent(t, spending="pocock") == pytest.approx(0.05 * math.log(
            1 + (math.e - 1) * t))
    levels = _rule.look_levels([3, 5], 5)
    assert levels[-1][0] == pytest.approx(0.05)
    assert sum(level for _, level in levels) == pytest.approx(0.05)
    with pytest.raises(ValueError, match="increase"):
        _rule.look_levels([5, 3], 5)
    with pytest.raises(ValueError, match="n_max"):
        _rule.look_levels([3, 6], 5)
    with pytest.raises(ValueError, match="spending"):
        _rule.spent(0.5, spending="haybittle")


def _false_reproduced(levels, counts, draws, rng) -> float:
    """Share of null experiments (mean 0) the looks call reproduced (the + side)."""
    x = rng.normal(0.0, 1.0, (draws, counts[-1]))
    hit = np.zeros(draws, dtype=bool)
    for n, level in zip(counts, levels, strict=True):
        m, se = x[:, :n].mean(axis=1), x[:, :n].std(axis=1, ddof=1) / math.sqrt(n)
        hit |= m - stats.t.ppf(1 - level / 2, n - 1) * se > 0
    return float(hit.mean())


def test_two_looks_keep_the_false_reproduced_rate():
    """The design the reruns followed (3 seeds, then 5) judged twice at 0.05 calls about 4% of
    null claims reproduced; spent by O'Brien-Fleming it stays at or under the nominal 2.5%.
    40,000 draws: standard error <= 0.001; the bounds sit 4 standard errors out (a false
    failure about 3e-5 each)."""
    rng = np.random.default_rng(7)
    counts = [3, 5]
    naive = _false_reproduced([0.05, 0.05], counts, 40_000, rng)
    corrected = _false_reproduced([lv for _, lv in _rule.look_levels(counts, 5)], counts,
                                  40_000, rng)
    assert naive > 0.025 + 4 * 0.001
    assert corrected < 0.025 + 4 * 0.001


def _result(rows, looks=(), name="x"):
    return ExperimentResult(name, "paper", {}, list(range(len(rows))), rows,
                            looks=[list(look) for look in looks])


def _claim(**kw):
    return Claim("x/c", "claim", "line", "superiority", "a", "b", **kw)


def test_a_claim_stops_at_the_first_look_that_decides_it():
    big = [{"a": 1.0 + 0.01 * i, "b": 0.0} for i in range(5)]
    v = verdict(_result(big, looks=[[0, 1, 2], [0, 1, 2, 3, 4]]), _claim(max_seeds=5))
    first = _rule.look_levels([3, 5], 5)[0]
    assert v["verdict"] == "reproduced" and v["decided_at"] == 1
    assert v["alpha_spent"] == pytest.approx(first[0]) and v["n"] == 5
    d = np.array([1.0, 1.01, 1.02])
    low = d.mean() - stats.t.ppf(1 - first[1] / 2, 2) * stats.sem(d)
    assert v["low"] == pytest.approx(low)
    assert [look["n"] for look in v["looks"]] == [3, 5] and v["fresh"] == "reproduced"


def test_a_decision_at_the_last_look_is_judged_at_what_is_left():
    rng = np.random.default_rng(3)
    diffs = rng.normal(0.3, 0.5, 17)
    rows = [{"a": float(x), "b": 0.0} for x in diffs]
    v = verdict(_result(rows, looks=[list(range(6))]), _claim(max_seeds=17))
    level = _rule.look_levels([6, 17], 17)[1][1]
    low, high = stats.t.interval(1 - level, 16, loc=diffs.mean(), scale=stats.sem(diffs))
    assert v["looks"][1]["level"] == pytest.approx(level)
    if v["decided_at"] == 2:
        assert v["low"] == pytest.approx(low) and v["high"] == pytest.approx(high)
    assert v["verdict"] == ("reproduced" if low > 0 else "inconclusive") or v["decided_at"] == 1
    beyond = verdict(_result(rows), _claim(max_seeds=10))
    assert beyond["verdict"] == "not comparable" and "fresh seeds" in beyond["reason"]


def test_looks_are_recorded_by_merges_and_checked():
    rows = [{"a": 0.1 * i, "b": 0.0} for i in range(5)]
    early = ExperimentResult("x", "paper", {}, [0, 1, 2], rows[:3])
    later = ExperimentResult("x", "paper", {}, [3, 4], rows[3:])
    merged = later._merged_with(early)
    assert merged.looks == [[0, 1, 2], [0, 1, 2, 3, 4]]
    assert looks_of(merged) == merged.looks
    assert looks_of(early) == [[0, 1, 2]]
    from qdensity_paper.merge import merge_results

    assert merge_results([early, later]).looks == [[0, 1, 2], [0, 1, 2, 3, 4]]
    assert merge_results([early]).looks == [[0, 1, 2]]
    with pytest.raises(ValueError, match="looks"):
        ExperimentResult("x", "paper", {}, [0, 1], rows[:2], looks=[[0, 1], [0]])
    with pytest.raises(ValueError, match="looks"):
        ExperimentResult("x", "paper", {}, [0, 1], rows[:2], looks=[[0, 7]])


def test_monotone_claims_are_judged_step_by_step():
    grid = (1, 2, 3)
    rows = [{"D1": 0.5 + e, "D2": 0.6 + e + 0.002 * i, "D3": 0.6 + e - 0.002 * i}
            for i, e in enumerate([0.0, 0.01, -0.01, 0.02, 0.005])]
    claim = Claim("x/m", "rises", "line", "monotone", series=tuple((d, f"D{d}") for d in grid))
    v = verdict(_result(rows), claim)
    steps = [np.array([r["D2"] - r["D1"] for r in rows]),
             np.array([r["D3"] - r["D2"] for r in rows])]
    for got, d in zip(v["steps"], steps, strict=True):
        low, high = stats.t.interval(0.95, 4, loc=d.mean(), scale=stats.sem(d))
        assert got["low"] == pytest.approx(low) and got["high"] == pytest.approx(high)
    # the first step rises clearly, the second is flat: a slope would call it a rise
    assert [s["verdict"] for s in v["steps"]][0] == "reproduced"
    assert v["verdict"] != "reproduced"


def test_a_composite_is_reproduced_only_when_every_part_is():
    whole = next(c for c in CLAIMS if c.key == "equivariant/all-cases")
    base = {f"{f}/{k}": 0.5 for f in ("xx", "noncommuting", "qcnn")
            for k in ("base_test_accuracy", "density_test_accuracy")}

    def rows(gains):
        noise = (0.010, -0.012, 0.004, -0.006, 0.003)  # mean -0.0002: no effect of its own
        return [{**base, **{f"{f}/density_test_accuracy": 0.5 + g + e
                            for f, g in gains.items()}} for e in noise]

    up = {"xx": 0.05, "noncommuting": 0.05, "qcnn": 0.05}
    flat = {**up, "qcnn": 0.0}
    down = {**up, "noncommuting": -0.05}
    with pytest.MonkeyPatch.context() as mp:  # the experiment's own departures aside
        mp.setattr("qdensity_paper.verdicts.departures_for", lambda result: [])
        assert verdict(_result(rows(up), name="equivariant"), whole)["verdict"] == "reproduced"
        assert verdict(_result(rows(flat), name="equivariant"), whole)["verdict"] == (
            "inconclusive")
        assert verdict(_result(rows(down), name="equivariant"), whole)["verdict"] == (
            "not reproduced")


def test_the_headline_counts_paper_claims_only():
    rows = [{"key": c.key, "verdict": "reproduced", "mode": "paper"} for c in CLAIMS]
    heads = headline(rows)
    assert set(heads) == {c.key for c in CLAIMS if counted(c)}
    assert all(c.category == "paper" and not c.part_of and not c.beside
               for c in CLAIMS if c.key in heads)
    for key in ("orthoqnn-depth/circuits-pure", "dropout/mitigates", "pyramid-shots/budget",
                "mixing-lemma/lemma-1", "equivariant/qcnn",
                "pyramid-shots/odd-even-best-trial"):
        assert key not in heads
    mixed = headline([{"key": "lcu-vs-single/lcu-beats-single", "verdict": v, "mode": "paper"}
                      for v in ("reproduced", "inconclusive")])
    assert mixed["lcu-vs-single/lcu-beats-single"] == "inconclusive"


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text).strip()


def test_every_paper_claim_quotes_the_paper_verbatim():
    """Each clause of a `paper` claim's quote occurs in one of the paper's sentences (the
    fixture, transcribed from the LaTeX source with markup read as text), at the place the
    claim names; `extension` and `structural` claims need none."""
    fixture = json.loads((HERE / "paper_sentences.json").read_text(encoding="utf-8"))
    sentences = fixture["sentences"]
    for s in sentences:
        assert _plain(s["sentence"]).endswith("."), s
    for c in CLAIMS:
        if c.category != "paper" or c.part_of:  # a part is quoted by its sentence's claim
            continue
        assert c.quote, c.key
        for clause in c.quote:
            assert any(_plain(clause) in _plain(s["sentence"]) and s["where"] == c.line
                       for s in sentences), (c.key, clause)
    with pytest.raises(ValueError, match="category"):
        Claim("x/c", "c", "l", "superiority", "a", "b", category="mine")
    with pytest.raises(ValueError, match="composite"):
        Claim("x/c", "c", "l", "composite")
