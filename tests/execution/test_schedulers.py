"""Tests for the shot-budget schedulers of the randomised density QNN (Fig. 1c).

Oracles: hand-computed allocations, brute-force integer optima, exact sub-unitary means
(closed forms and cosines of RY rotations), and statistical bounds over many fixed seeds.
The synthetic shot sources here are written independently of ``qdensity.execution.schedulers``.
"""

from __future__ import annotations

import functools
import itertools
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import ClassicalRegister, QuantumCircuit, QuantumRegister, transpile
from qiskit.circuit import Parameter
from qiskit.primitives import BaseSamplerV2
from qiskit_aer.primitives import SamplerV2
from scipy.stats import chi2
from scipy.stats import t as t_dist

from qdensity.execution.schedulers import (
    NeymanScheduler,
    PerShotScheduler,
    ProportionalScheduler,
    ScheduleResult,
    allocate_neyman,
    allocate_proportional,
    discrete_source,
    neyman,
    per_shot,
    per_shot_variance,
    proportional,
    sampler_source,
    stratified_variance,
)

SCHEDULERS = [per_shot, proportional, neyman]


# ------------------------------------------------------------------------------------------
# Independent synthetic sources
# ------------------------------------------------------------------------------------------


class PlusMinusSource:
    """Stratum k yields +1 with probability (1 + m_k) / 2, else -1; counts every shot asked for."""

    def __init__(self, means):
        self.means = np.asarray(means, dtype=float)
        self.requested = 0
        self.calls = 0

    def __call__(self, shots, rng):
        shots = np.asarray(shots)
        assert shots.shape == self.means.shape
        assert np.all(shots >= 0)
        self.requested += int(shots.sum())
        self.calls += 1
        p_plus = (1 + self.means) / 2
        return [np.where(rng.random(n) < p_plus[k], 1.0, -1.0) for k, n in enumerate(shots)]


def _alpha_strategy(max_k=8, allow_zero=True):
    weights = st.lists(st.integers(0 if allow_zero else 1, 20), min_size=1, max_size=max_k).filter(
        lambda w: sum(w) > 0
    )
    return weights.map(lambda w: np.array(w, dtype=float) / sum(w))


# ------------------------------------------------------------------------------------------
# Allocations
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("alpha", "budget", "expected"),
    [
        ([0.5, 0.3, 0.2], 10, [5, 3, 2]),
        ([1 / 3, 1 / 3, 1 / 3], 10, [4, 3, 3]),  # tie on the remainder: lower index first
        ([0.98, 0.01, 0.01, 0.0], 10, [8, 1, 1, 0]),  # quotas 9.8, .1, .1 -> 10, 0, 0 -> floor
        ([0.0, 1.0], 7, [0, 7]),
        ([0.45, 0.45, 0.1], 3, [1, 1, 1]),
        ([0.26, 0.74], 5, [1, 4]),  # quotas 1.3, 3.7
    ],
)
def test_allocate_proportional_hand_examples(alpha, budget, expected):
    assert allocate_proportional(alpha, budget).tolist() == expected


@settings(max_examples=60, deadline=None)
@given(alpha=_alpha_strategy(), extra=st.integers(0, 300))
def test_allocate_proportional_sum_and_floor(alpha, extra):
    positive = alpha > 0
    budget = int(positive.sum()) + extra
    n = allocate_proportional(alpha, budget)
    assert n.dtype == np.int64
    assert n.sum() == budget
    assert np.all(n[positive] >= 1)
    assert np.all(n[~positive] == 0)
    quota = alpha * budget
    if np.all(quota[positive] >= 1):  # no floor adjustment: largest remainder stays within 1
        assert np.all(n >= np.floor(quota - 1e-9))
        assert np.all(n <= np.ceil(quota + 1e-9))


@settings(max_examples=40, deadline=None)
@given(alpha=_alpha_strategy(max_k=6), extra=st.integers(0, 100))
def test_allocate_proportional_minimum_two(alpha, extra):
    positive = alpha > 0
    budget = 2 * int(positive.sum()) + extra
    n = allocate_proportional(alpha, budget, minimum=2)
    assert n.sum() == budget
    assert np.all(n[positive] >= 2)
    assert np.all(n[~positive] == 0)


def test_allocate_neyman_hand_examples():
    # weights alpha*sigma = 0.5, 0.125 -> 80 / 20
    assert allocate_neyman([0.5, 0.5], [1.0, 0.25], 100).tolist() == [80, 20]
    # zero spread still gets the one-shot minimum; the rest goes to the spread stratum
    assert allocate_neyman([0.5, 0.5], [1.0, 0.0], 10).tolist() == [9, 1]
    # all spreads zero: proportional
    assert allocate_neyman([0.7, 0.3], [0.0, 0.0], 10).tolist() == [7, 3]
    # zero alpha gets nothing whatever its spread
    assert allocate_neyman([1.0, 0.0], [0.1, 5.0], 4).tolist() == [4, 0]


@settings(max_examples=60, deadline=None)
@given(
    alpha=_alpha_strategy(),
    data=st.data(),
    extra=st.integers(0, 300),
)
def test_allocate_neyman_sum_floor_and_quota(alpha, data, extra):
    sigma = np.array(data.draw(st.lists(st.floats(0, 2), min_size=alpha.size, max_size=alpha.size)))
    positive = alpha > 0
    budget = int(positive.sum()) + extra
    n = allocate_neyman(alpha, sigma, budget)
    assert n.sum() == budget
    assert np.all(n[positive] >= 1)
    assert np.all(n[~positive] == 0)
    w = alpha * sigma
    if w.sum() > 0:
        quota = w / w.sum() * budget
        if np.all(quota[positive] >= 1):
            assert np.all(n >= np.floor(quota - 1e-9))
            assert np.all(n <= np.ceil(quota + 1e-9))


def test_allocate_neyman_near_integer_optimum():
    """Against brute force over every integer allocation with n_k >= 1 (K = 3)."""
    rng = np.random.default_rng(11)
    for _ in range(25):
        alpha = rng.dirichlet(np.ones(3))
        sigma = rng.uniform(0.05, 1.0, 3)
        budget = int(rng.integers(24, 40))
        w2 = (alpha * sigma) ** 2
        best = min(
            float(np.sum(w2 / np.array(c)))
            for c in itertools.product(range(1, budget), repeat=3)
            if sum(c) == budget
        )
        got = float(np.sum(w2 / allocate_neyman(alpha, sigma, budget)))
        assert best <= got <= 1.02 * best
        # and never meaningfully worse than proportional
        prop = float(np.sum(w2 / allocate_proportional(alpha, budget)))
        assert got <= 1.01 * prop


def test_variance_formulas_against_closed_forms():
    alpha = np.array([0.5, 0.25, 0.25])
    means = np.array([1.0, 0.0, -1.0])
    variances = np.array([0.0, 1.0, 0.0])
    # f = 0.25; E[v^2] = 0.5 + 0.25 + 0.25 = 1 -> per-shot variance (1 - 1/16) / 8
    assert per_shot_variance(alpha, means, variances, 8) == pytest.approx((1 - 1 / 16) / 8)
    assert stratified_variance(alpha, variances, [4, 2, 2]) == pytest.approx(0.0625 / 2)
    with pytest.raises(ValueError, match="alpha_k > 0"):
        stratified_variance(alpha, variances, [8, 0, 0])


# ------------------------------------------------------------------------------------------
# Bad input
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("fn", SCHEDULERS)
@pytest.mark.parametrize(
    ("alpha", "match"),
    [
        ([0.5, -0.1, 0.6], "non-negative"),
        ([0.5, np.nan, 0.5], "finite"),
        ([0.5, 0.4], "sum to 1"),
        ([0.5, 0.5 + 1e-6], "sum to 1"),
    ],
)
def test_bad_alpha(fn, alpha, match):
    with pytest.raises(ValueError, match=match):
        fn(alpha, 100, PlusMinusSource(np.zeros(len(alpha))), seed=0)


@pytest.mark.parametrize("fn", SCHEDULERS)
@pytest.mark.parametrize("budget", [10.0, True, "10", None])
def test_budget_must_be_int(fn, budget):
    with pytest.raises(TypeError, match="budget"):
        fn([0.5, 0.5], budget, PlusMinusSource([0, 0]), seed=0)


def test_budget_too_small():
    alpha = [0.5, 0.3, 0.2, 0.0]
    with pytest.raises(ValueError, match=r"budget must be >= 3"):
        proportional(alpha, 2, PlusMinusSource(np.zeros(4)), seed=0)
    with pytest.raises(ValueError, match=r"budget must be >= 9"):
        neyman(alpha, 8, PlusMinusSource(np.zeros(4)), seed=0)
    with pytest.raises(ValueError, match="budget must be an int >= 1"):
        per_shot(alpha, 0, PlusMinusSource(np.zeros(4)), seed=0)
    with pytest.raises(ValueError, match="budget"):
        allocate_proportional(alpha, 2)
    with pytest.raises(ValueError, match="budget"):
        allocate_neyman(alpha, [1, 1, 1, 1], 2)
    # the smallest allowed budgets work
    assert proportional(alpha, 3, PlusMinusSource(np.zeros(4)), seed=0).shots_used == 3
    res = neyman(alpha, 9, PlusMinusSource(np.zeros(4)), seed=0)
    assert res.shots_used == 9
    assert res.pilot_allocation.tolist() == [2, 2, 2, 0]
    assert res.allocation.tolist() == [1, 1, 1, 0]


def test_bad_sigma_and_value_range_and_pilot():
    with pytest.raises(ValueError, match="sigma must be non-negative"):
        allocate_neyman([0.5, 0.5], [1.0, -1.0], 10)
    with pytest.raises(ValueError, match="shape"):
        allocate_neyman([0.5, 0.5], [1.0], 10)
    with pytest.raises(ValueError, match="value_range"):
        proportional([1.0], 5, PlusMinusSource([0]), seed=0, value_range=(1, -1))
    with pytest.raises(ValueError, match="pilot_fraction"):
        NeymanScheduler(pilot_fraction=1.0)
    with pytest.raises(ValueError, match="prior_weight"):
        NeymanScheduler(prior_weight=-1.0)


@pytest.mark.parametrize("fn", SCHEDULERS)
def test_source_returning_wrong_things(fn):
    def too_few(shots, rng):
        return [np.ones(n) for n in shots[:-1]]

    def wrong_length(shots, rng):
        return [np.ones(n + 1) for n in shots]

    def out_of_range(shots, rng):
        return [np.full(n, 2.0) for n in shots]

    with pytest.raises(ValueError, match="returned 1 value arrays, expected 2"):
        fn([0.5, 0.5], 30, too_few, seed=0)
    with pytest.raises(ValueError, match="asked for"):
        fn([0.5, 0.5], 30, wrong_length, seed=0)
    with pytest.raises(ValueError, match="value_range"):
        fn([0.5, 0.5], 30, out_of_range, seed=0)
    # a declared wider range accepts the values
    assert fn([0.5, 0.5], 30, out_of_range, seed=0, value_range=(0, 2)).estimate == pytest.approx(2)


# ------------------------------------------------------------------------------------------
# Budgets are never exceeded
# ------------------------------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(alpha=_alpha_strategy(max_k=6), extra=st.integers(0, 80), seed=st.integers(0, 2**16))
def test_budget_exact_for_every_scheduler(alpha, extra, seed):
    positive = int((alpha > 0).sum())
    budget = 3 * positive + extra
    means = np.linspace(-0.8, 0.8, alpha.size)
    for fn in SCHEDULERS:
        src = PlusMinusSource(means)
        res = fn(alpha, budget, src, seed=seed)
        assert isinstance(res, ScheduleResult)
        assert src.requested == res.shots_used == budget
        pilot = 0 if res.pilot_allocation is None else int(res.pilot_allocation.sum())
        assert int(res.allocation.sum()) + pilot == budget
        if fn is not per_shot:
            assert np.all(res.allocation[alpha == 0] == 0)
            assert np.all(res.allocation[alpha > 0] >= 1)
        got = res.allocation + (0 if res.pilot_allocation is None else res.pilot_allocation)
        assert np.all(np.isnan(res.per_subunitary[got == 0]))
        assert np.all(np.isfinite(res.per_subunitary[got > 0]))


# ------------------------------------------------------------------------------------------
# Statistics: unbiasedness and honest standard errors
# ------------------------------------------------------------------------------------------

ALPHA = np.array([0.4, 0.3, 0.2, 0.1])
MEANS = np.array([0.9, -0.5, 0.1, 0.95])
TRUE_F = float(ALPHA @ MEANS)
N_SEEDS = 400
#: Each statistical check below fails with probability at most RATE for a random seed set
#: (``benchmarks/fuzz_statistics.py`` runs them over 50 seed sets).
RATE = 1e-3


def _first_seed() -> int:
    """Seeds run ``first .. first + N_SEEDS - 1``; ``QDENSITY_STAT_SEED`` shifts them."""
    return int(os.environ.get("QDENSITY_STAT_SEED", 0)) * N_SEEDS


def _var_bounds(n: int, rate: float = RATE) -> tuple[float, float]:
    """Bounds on ``s^2 / sigma^2`` for ``n`` normal draws: ``(n - 1) s^2 / sigma^2`` is
    chi-square with ``n - 1`` degrees of freedom; outside with probability ``rate``. (The
    estimates are means of 100-200 bounded shots, normal to well within this rate.)"""
    return chi2.ppf(rate / 2, n - 1) / (n - 1), chi2.isf(rate / 2, n - 1) / (n - 1)


def _repeat(fn, budget, means=MEANS, alpha=ALPHA, n_seeds=N_SEEDS):
    src = PlusMinusSource(means)
    first = _first_seed()
    results = [fn(alpha, budget, src, seed=s) for s in range(first, first + n_seeds)]
    assert src.requested == n_seeds * budget
    est = np.array([r.estimate for r in results])
    se = np.array([r.standard_error for r in results])
    return est, se


@pytest.mark.parametrize("fn", SCHEDULERS)
def test_unbiased_and_standard_error_calibrated(fn):
    budget = 200
    est, se = _repeat(fn, budget)
    sem = est.std(ddof=1) / np.sqrt(est.size)
    # Student t with 399 degrees of freedom: |t| > z with probability RATE / 2
    assert abs(est.mean() - TRUE_F) < t_dist.isf(RATE / 4, est.size - 1) * sem
    # reported standard errors agree with the spread over seeds: the mean of 400 reported
    # variances is nearly exact, so the sample variance over seeds over it is chi-square/dof
    low, high = _var_bounds(est.size, RATE / 2)
    assert low <= est.var(ddof=1) / np.mean(se**2) <= high


def test_exact_variances_match_closed_forms():
    """Empirical variances over seeds against independently written closed forms."""
    budget = 200
    var_k = 1 - MEANS**2  # variance of a +-1 value with mean m
    low, high = _var_bounds(N_SEEDS, RATE / 2)  # two checks share RATE
    # per-shot: a single value has variance 1 - f^2
    est, _ = _repeat(per_shot, budget)
    assert low <= est.var(ddof=1) / ((1 - TRUE_F**2) / budget) <= high
    # proportional: 200 * alpha = 80, 60, 40, 20 shots exactly
    est, _ = _repeat(proportional, budget)
    expected = np.sum(ALPHA**2 * var_k / np.array([80, 60, 40, 20]))
    assert low <= est.var(ddof=1) / expected <= high


def test_proportional_beats_per_shot_when_means_differ():
    alpha = np.array([0.4, 0.4, 0.2])
    means = np.array([0.9, -0.9, 0.0])
    budget = 100
    # closed forms: per-shot (1 - f^2)/S = 0.01; proportional sum alpha (1 - m^2)/S = 0.00352
    est_ps, _ = _repeat(per_shot, budget, means, alpha)
    est_pr, _ = _repeat(proportional, budget, means, alpha)
    low, high = _var_bounds(N_SEEDS, RATE / 3)  # three checks share RATE
    assert est_pr.var(ddof=1) < 0.6 * est_ps.var(ddof=1)  # 0.352 x F(399, 399) quantile < 0.6
    assert low <= est_ps.var(ddof=1) / 0.01 <= high
    assert low <= est_pr.var(ddof=1) / 0.00352 <= high


def test_neyman_beats_proportional_when_spreads_differ():
    # two strata with equal alpha: one deterministic (sigma 0), one a fair coin (sigma 1)
    alpha = np.array([0.5, 0.5])
    means = np.array([1.0, 0.0])
    budget = 200
    est_pr, _ = _repeat(proportional, budget, means, alpha)
    plain = functools.partial(neyman, prior_weight=0.0)
    est_ny0, _ = _repeat(plain, budget, means, alpha)
    est_ny, _ = _repeat(neyman, budget, means, alpha)
    # proportional: 0.25 * 1 / 100 = 0.0025. Neyman, plain pilot variances: pilot 40 shots
    # (20 each), then 159 of the remaining 160 to the coin:
    # 0.2^2 * 0.25/20 + 0.8^2 * 0.25/159 = 0.0015063
    assert est_pr.var(ddof=1) == pytest.approx(0.0025, rel=0.2)
    assert est_ny0.var(ddof=1) == pytest.approx(0.0015063, rel=0.2)
    # default shrinkage (one pseudo-shot of variance 1): main split about 29 / 131,
    # 0.2^2 * 0.25/20 + 0.8^2 * 0.25/131 = 0.0017214
    assert est_ny.var(ddof=1) == pytest.approx(0.0017214, rel=0.2)
    assert est_ny.var(ddof=1) < 0.8 * est_pr.var(ddof=1)
    for est in (est_ny0, est_ny):
        assert abs(est.mean() - 0.5) < 4 * est.std(ddof=1) / np.sqrt(est.size)


def test_neyman_allocation_follows_spreads_and_falls_back():
    alpha = np.array([0.5, 0.5])

    def alternating(shots, rng):  # stratum 0 constant, stratum 1 +1, -1, +1, ...
        return [np.ones(shots[0]), (-1.0) ** np.arange(shots[1])]

    res = neyman(alpha, 200, alternating, seed=3, prior_weight=0.0)
    assert res.pilot_allocation.tolist() == [20, 20]
    assert res.allocation.tolist() == [1, 159]  # sigma_0 = 0 gets only the minimum
    assert not res.info["fallback"]
    # shrunk spreads: sigma^2 = (SS + 1) / (20 - 1 + 1): SS_0 = 0, SS_1 = 20 (ten +1, ten -1)
    res = neyman(alpha, 200, alternating, seed=3)
    s0, s1 = np.sqrt(1 / 20), np.sqrt(21 / 20)
    quota0 = 160 * s0 / (s0 + s1)  # 28.66 -> largest remainder gives 29
    assert res.allocation.tolist() == [round(quota0), 160 - round(quota0)] == [29, 131]
    np.testing.assert_allclose(res.info["allocation_sigma"], [s0, s1])
    # every stratum deterministic: no spread to exploit -> proportional, exact answer
    res = neyman([0.7, 0.3], 100, PlusMinusSource([1.0, -1.0]), seed=3)
    assert res.info["fallback"]
    assert res.allocation.tolist() == [56, 24]
    assert res.estimate == pytest.approx(0.4)
    # no spread was seen, but the error does not claim certainty (Wilson term R^2 / (4 n^2))
    assert 0.0 < res.standard_error < 0.05


def test_neyman_estimator_is_fixed_weight_combination():
    """estimate = (P/S) * pilot estimate + (1 - P/S) * main estimate, from the raw shots."""
    calls = []

    def recording(shots, rng):
        out = PlusMinusSource([0.3, -0.2, 0.6])(shots, rng)
        calls.append(out)
        return out

    alpha = np.array([0.2, 0.5, 0.3])
    res = neyman(alpha, 300, recording, seed=5, pilot_fraction=0.25)
    assert len(calls) == 2
    pilot, main = calls
    assert [len(v) for v in pilot] == res.pilot_allocation.tolist()
    assert [len(v) for v in main] == res.allocation.tolist()
    f_pilot = sum(a * v.mean() for a, v in zip(alpha, pilot, strict=True))
    f_main = sum(a * v.mean() for a, v in zip(alpha, main, strict=True))
    lam = res.pilot_allocation.sum() / 300
    assert lam == 0.25
    assert res.estimate == pytest.approx(lam * f_pilot + (1 - lam) * f_main, abs=1e-12)
    pooled = [np.concatenate([p, m]).mean() for p, m in zip(pilot, main, strict=True)]
    np.testing.assert_allclose(res.per_subunitary, pooled, atol=1e-12)


def test_seed_reproducibility_and_generator_input():
    for fn in SCHEDULERS:
        a = fn(ALPHA, 120, PlusMinusSource(MEANS), seed=42)
        b = fn(ALPHA, 120, PlusMinusSource(MEANS), seed=42)
        c = fn(ALPHA, 120, PlusMinusSource(MEANS), seed=np.random.default_rng(42))
        assert a.estimate == b.estimate == c.estimate
        np.testing.assert_array_equal(a.allocation, b.allocation)


def test_single_shot_strata_use_conservative_variance():
    # budget 3 over three strata: one shot each, variance bound (b - a)^2 / 4 = 1 for +-1 values
    res = proportional([0.5, 0.25, 0.25], 3, PlusMinusSource([1.0, 1.0, 1.0]), seed=0)
    assert res.standard_error == pytest.approx(np.sqrt(0.25 + 0.0625 + 0.0625))
    res = ProportionalScheduler(value_range=(0, 4)).run(
        [0.5, 0.5], 2, lambda s, r: [np.full(n, 1.0) for n in s], seed=0
    )
    assert res.standard_error == pytest.approx(np.sqrt(0.25 * 4 + 0.25 * 4))
    res = PerShotScheduler().run([1.0], 1, PlusMinusSource([0.0]), seed=0)
    assert res.standard_error == 1.0


# ------------------------------------------------------------------------------------------
# discrete_source
# ------------------------------------------------------------------------------------------


def test_discrete_source_frequencies():
    probs = np.array([[0.2, 0.3, 0.5], [1.0, 0.0, 0.0]])
    src = discrete_source(probs, [10.0, 20.0, 30.0])
    out = src(np.array([20000, 7]), np.random.default_rng(0))
    assert [v.shape for v in out] == [(20000,), (7,)]
    freq = np.array([np.mean(out[0] == v) for v in (10.0, 20.0, 30.0)])
    assert np.all(np.abs(freq - probs[0]) < 4 * np.sqrt(probs[0] * (1 - probs[0]) / 20000))
    assert np.all(out[1] == 10.0)
    with pytest.raises(ValueError, match="probabilities"):
        discrete_source([[0.5, 0.6]], [1, 2])
    with pytest.raises(ValueError, match="shape"):
        src(np.array([1, 2, 3]), None)


# ------------------------------------------------------------------------------------------
# sampler_source on qiskit-aer's SamplerV2
# ------------------------------------------------------------------------------------------

THETAS = np.array([0.4, 1.3, 2.2])


def _ry_circuits(thetas=THETAS):
    out = []
    for theta in thetas:
        qc = QuantumCircuit(1, 1)
        qc.ry(theta, 0)
        qc.measure(0, 0)
        out.append(qc)
    return out


def _z_value(bits):
    return (-1.0) ** (bits & 1)


class SpySampler(BaseSamplerV2):
    """Aer's SamplerV2 that records every PUB it is given."""

    def __init__(self, seed):
        self.inner = SamplerV2(seed=seed)
        self.jobs = []

    def run(self, pubs, *, shots=None):
        pubs = list(pubs)
        self.jobs.append([(p[0], p[2]) for p in pubs])
        return self.inner.run(pubs, shots=shots)


def test_sampler_source_one_job_per_shot_count_skips_empty_pubs():
    circuits = _ry_circuits()
    spy = SpySampler(seed=1)
    src = sampler_source(circuits, _z_value, sampler=spy)
    out = src(np.array([5, 0, 3]), np.random.default_rng(0))
    assert [v.shape for v in out] == [(5,), (0,), (3,)]
    # one PUB per sub-unitary with shots, none for k = 1; one job per shot count
    assert [[(c is circuits[0], c is circuits[2], n) for c, n in job] for job in spy.jobs] == [
        [(True, False, 5)], [(False, True, 3)]]
    out = src(np.array([4, 0, 4]), np.random.default_rng(1))
    assert [v.shape for v in out] == [(4,), (0,), (4,)]
    assert [[n for _, n in job] for job in spy.jobs[2:]] == [[4, 4]]  # one count: one job
    out = src(np.array([0, 0, 0]), None)
    assert [v.shape for v in out] == [(0,), (0,), (0,)]
    assert len(spy.jobs) == 3  # nothing to run: no job


@pytest.mark.parametrize("fn", SCHEDULERS)
def test_sampler_source_unbiased_against_cosines(fn):
    alpha = np.array([0.5, 0.3, 0.2])
    exact = float(alpha @ np.cos(THETAS))  # <Z> after RY(theta) on |0> is cos(theta)
    src = sampler_source(_ry_circuits(), _z_value)
    spy_count = []

    def counting(shots, rng):
        spy_count.append(int(np.sum(shots)))
        return src(shots, rng)

    n_seeds, budget = 25, 300
    results = [fn(alpha, budget, counting, seed=s) for s in range(n_seeds)]
    assert sum(spy_count) == n_seeds * budget
    est = np.array([r.estimate for r in results])
    se = np.array([r.standard_error for r in results])
    sem = np.sqrt(np.mean(se**2) / n_seeds)
    assert abs(est.mean() - exact) < 4 * sem
    # per-sub-unitary means are honest too
    for r in results[:3]:
        z = (r.per_subunitary - np.cos(THETAS)) / np.sqrt(
            np.sin(THETAS) ** 2 / np.maximum(1, _total(r))
        )
        assert np.all(np.abs(z[np.isfinite(z)]) < 5)


def _total(res):
    return res.allocation + (0 if res.pilot_allocation is None else res.pilot_allocation)


def test_sampler_source_reproducible_with_seed():
    alpha = [0.5, 0.3, 0.2]
    for fn in SCHEDULERS:
        src = sampler_source(_ry_circuits(), _z_value)
        a = fn(alpha, 200, src, seed=9)
        b = fn(alpha, 200, src, seed=9)
        c = fn(alpha, 200, src, seed=10)
        assert a.estimate == b.estimate
        np.testing.assert_array_equal(a.per_subunitary, b.per_subunitary)
        assert a.estimate != c.estimate
    # the adapter's own seed governs calls made without a generator
    s1 = sampler_source(_ry_circuits(), _z_value, seed=4)
    s2 = sampler_source(_ry_circuits(), _z_value, seed=4)
    for u, v in zip(s1([50, 50, 50]), s2([50, 50, 50]), strict=True):
        np.testing.assert_array_equal(u, v)


def test_sampler_source_successive_calls_independent():
    """Pilot and main phases must not reuse the simulator's random stream."""
    qc = QuantumCircuit(1, 1)
    qc.h(0)
    qc.measure(0, 0)
    src = sampler_source([qc], _z_value)
    rng = np.random.default_rng(0)
    a, b = src([2000], rng)[0], src([2000], rng)[0]
    agree = np.mean(a == b)  # fair coins: agreement rate 1/2
    assert abs(agree - 0.5) < 4 * 0.5 / np.sqrt(2000)


def test_sampler_source_bit_order_multiple_registers_and_parameters():
    q = QuantumRegister(3)
    creg_b = ClassicalRegister(1, "b")
    creg_a = ClassicalRegister(2, "a")
    qc = QuantumCircuit(q, creg_b, creg_a)
    qc.x(0)
    qc.measure(q[0], creg_a[1])  # clbit index 2
    qc.measure(q[1], creg_a[0])
    qc.measure(q[2], creg_b[0])
    assert qc.find_bit(creg_a[1]).index == 2
    src = sampler_source([qc], lambda b: b.astype(float), seed=0)
    np.testing.assert_array_equal(src([4])[0], [4.0] * 4)

    theta = Parameter("t")
    pc = QuantumCircuit(1, 1)
    pc.ry(theta, 0)
    pc.measure(0, 0)
    src = sampler_source([pc, pc], _z_value, parameter_values=[[0.0], [np.pi]], seed=0)
    out = src([10, 10])
    np.testing.assert_array_equal(out[0], np.ones(10))
    np.testing.assert_array_equal(out[1], -np.ones(10))


def test_sampler_source_transpiled_circuits_with_given_sampler():
    circuits = [
        transpile(c, basis_gates=["cz", "rz", "sx", "x"], optimization_level=1)
        for c in _ry_circuits()
    ]
    src = sampler_source(circuits, _z_value, sampler=SamplerV2(seed=123))
    res = proportional([0.5, 0.3, 0.2], 3000, src, seed=0)
    exact = float(np.array([0.5, 0.3, 0.2]) @ np.cos(THETAS))
    assert abs(res.estimate - exact) < 5 * res.standard_error


def test_sampler_source_bad_input():
    circuits = _ry_circuits()
    with pytest.raises(TypeError, match="circuits must be a list or tuple"):
        sampler_source(circuits[0], _z_value)
    with pytest.raises(TypeError, match=r"circuits\[1\]"):
        sampler_source([circuits[0], "x"], _z_value)
    with pytest.raises(ValueError, match="classical bits"):
        sampler_source([QuantumCircuit(1)], _z_value)
    with pytest.raises(TypeError, match="values_fn"):
        sampler_source(circuits, None)
    with pytest.raises(TypeError, match="BaseSamplerV2"):
        sampler_source(circuits, _z_value, sampler=object())
    pc = QuantumCircuit(1, 1)
    pc.ry(Parameter("t"), 0)
    pc.measure(0, 0)
    with pytest.raises(ValueError, match="parameter_values"):
        sampler_source([pc], _z_value)
    with pytest.raises(ValueError, match="parameter_values"):
        sampler_source([pc], _z_value, parameter_values=[[0.1, 0.2]])
    with pytest.raises(ValueError, match="one entry per circuit"):
        sampler_source(circuits, _z_value, parameter_values=[None])
    src = sampler_source(circuits, lambda b: np.ones(3))
    with pytest.raises(ValueError, match="values_fn"):
        src([5, 0, 0], None)
    with pytest.raises(ValueError, match="shape"):
        sampler_source(circuits, _z_value)([1, 2], None)
    with pytest.raises(ValueError, match="non-negative"):
        sampler_source(circuits, _z_value)([1, -2, 1], None)


def test_neyman_tells_a_phase_aware_source_pilot_then_main():
    """A source taking ``phase`` hears "pilot" for the pilot_allocation and "main" for the
    allocation; sources without it, and per_shot and proportional, call it as before."""
    calls = []
    plain = PlusMinusSource([0.2, -0.5, 0.9])

    def source(shots, rng, phase="none"):
        calls.append((phase, np.asarray(shots).tolist()))
        return plain(shots, rng)

    alpha = [0.5, 0.3, 0.2]
    res = neyman(alpha, 600, source, seed=1)
    assert calls == [("pilot", res.pilot_allocation.tolist()), ("main", res.allocation.tolist())]
    calls.clear()
    proportional(alpha, 600, source, seed=1)
    per_shot(alpha, 600, source, seed=1)
    assert [phase for phase, _ in calls] == ["none", "none"]
    assert neyman(alpha, 600, PlusMinusSource([0.2, -0.5, 0.9]), seed=1).shots_used == 600
