"""Fuzzing ``qdensity.execution``: plans, engines, schedulers, allocations, intervals.

Valid: exact probabilities of random parameter rows match ``Statevector`` (independent);
allocations sum to the budget. Invalid input raises ``ValueError``/``TypeError`` only; zero
parameter rows (an Aer segfault before) and over-wide circuits are refused before running.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _fuzz import BAD_SIZES, HUGE, NON_FINITE, NOT_A_NUMBER, accepted, poison, refused
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.execution.intervals import binomial_standard_error, wilson_standard_error
from qdensity.execution.plans import CircuitJob, expectation_plan, measured, probabilities_plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.schedulers import (
    allocate_neyman,
    allocate_proportional,
    discrete_source,
    neyman,
    per_shot,
    proportional,
)
from qdensity.validation import check_width

RR4 = round_robin(4)
ENGINE = ExactEngine()


# ----------------------------------------------------------------------------- found cases
def test_found_zero_parameter_rows_refused_before_aer():
    with pytest.raises(ValueError, match="at least one parameter row"):
        probabilities_plan(RR4, np.zeros((0, 6)))
    with pytest.raises(ValueError, match="at least one parameter row"):
        CircuitJob(measured(RR4), np.zeros((0, 6)))


def test_found_engine_options_refused():
    with pytest.raises(ValueError, match="optimization_level must be one of 0, 1, 2, 3"):
        SamplerEngine(optimization_level=7)
    with pytest.raises(ValueError, match="device must be one of 'CPU', 'GPU'"):
        ExactEngine(device="TPU")


def test_found_per_shot_source_must_be_callable():
    with pytest.raises(TypeError, match="source must be a callable"):
        per_shot([0.5, 0.5], 100, "src")


@pytest.mark.parametrize("sigma, budget", [(1e-308, 8), (5e-324, 1), (5e-324, 8)])
def test_found_neyman_tiny_sigma_does_not_overflow(sigma, budget):
    assert allocate_neyman([1.0], [sigma], budget).tolist() == [budget]
    assert allocate_neyman([0.5, 0.5], [sigma, 2 * sigma], 3 * budget).sum() == 3 * budget


def test_found_unseen_outcome_has_nonzero_error():
    # density round-robin n=4, 2000 shots: an outcome of exact probability 8.6e-4 may never
    # turn up; its error must not be zero (plug-in sqrt(p(1-p)/N) would be)
    se = binomial_standard_error(np.array([0.0, 1.0, 0.3]), 2000)
    assert np.all(se > 0)
    assert se[0] == pytest.approx(1 / (2 * 2000))
    assert se[2] >= math.sqrt(0.3 * 0.7 / 2000)
    plan = expectation_plan(QuantumCircuit(2), SparsePauliOp("ZZ"), None, shots=50)
    est = plan.run(SamplerEngine(seed=1))
    assert est.value[0] == 1.0 and est.standard_error[0] == pytest.approx(2 / (2 * 50))


def test_width_guard_names_limit_and_alternative():
    with pytest.raises(ValueError, match=r"at most 24 qubits.*unary engine.*MPS"):
        check_width(40)
    wide = QuantumCircuit(30)
    wide.h(0)
    with pytest.raises(ValueError, match="at most 24 qubits"):
        probabilities_plan(wide, None)
    with pytest.raises(ValueError, match=r"ExactEngine.*at most 24 qubits"):
        ENGINE.run([CircuitJob(measured(wide), None)])
    with pytest.raises(ValueError, match="at most 12 qubits"):
        ExactEngine(method="density_matrix").run([CircuitJob(measured(QuantumCircuit(13)),
                                                              None)])


# ----------------------------------------------------------------------------- valid input
@settings(max_examples=8)
@given(seed=st.integers(0, 2**16), rows=st.integers(1, 3))
def test_exact_probabilities_match_statevector(seed, rows):
    accepted("probabilities_plan+ExactEngine")
    vals = np.random.default_rng(seed).uniform(-np.pi, np.pi, (rows, RR4.num_parameters))
    x = QuantumCircuit(4)
    x.x(0)
    circ = x.compose(RR4)
    probs = probabilities_plan(circ, vals).run(ENGINE).probabilities
    for r in range(rows):
        oracle = Statevector(circ.assign_parameters(vals[r])).probabilities()
        np.testing.assert_allclose(probs[r], oracle, atol=1e-9)


@settings(max_examples=40)
@given(data=st.data())
def test_allocations_valid_sum_to_budget(data):
    accepted("allocate_neyman")
    k = data.draw(st.integers(1, 5))
    w = np.array(data.draw(st.lists(st.floats(0, 1), min_size=k, max_size=k)))
    alpha = (w + 1e-3) / (w + 1e-3).sum()
    sigma = np.array(data.draw(st.lists(st.floats(0, 1e300), min_size=k, max_size=k)))
    budget = k + data.draw(st.integers(0, 200))
    for n in (allocate_neyman(alpha, sigma, budget), allocate_proportional(alpha, budget)):
        assert n.sum() == budget and np.all(n >= 1)


# ----------------------------------------------------------------------------- invalid input
@settings(max_examples=60)
@given(data=st.data())
def test_plans_bad_input_refused(data):
    kind = data.draw(st.sampled_from(["nonfinite", "shape", "text", "shots", "circuit",
                                      "observable", "empty"]))
    vals, shots, circ, obs = np.zeros((2, 6)), None, RR4, SparsePauliOp("IIIZ")
    if kind == "nonfinite":
        vals = poison(vals, data)
    elif kind == "shape":
        vals = np.zeros(data.draw(st.sampled_from([(5,), (2, 7), (2, 2, 6), (0, 6)])))
    elif kind == "text":
        vals = data.draw(NOT_A_NUMBER.filter(lambda v: v is not None))
    elif kind == "shots":
        shots = data.draw(BAD_SIZES.filter(lambda v: v is not None))
    elif kind == "circuit":
        circ = data.draw(NOT_A_NUMBER)
    elif kind == "observable":
        obs = data.draw(st.sampled_from(["ZZ", "Q", 3.5, SparsePauliOp("Z", 1j)]))
    else:
        vals = np.zeros((0, 6))
    if kind != "observable":
        refused("probabilities_plan", probabilities_plan, circ, vals, shots=shots)
    refused("expectation_plan", expectation_plan, circ, obs, vals, shots=shots)


@settings(max_examples=40)
@given(data=st.data())
def test_engines_bad_options_refused(data):
    refused("ExactEngine", ExactEngine, method=data.draw(st.text(max_size=5)))
    refused("ExactEngine", ExactEngine, device=data.draw(st.one_of(
        st.text(max_size=4).filter(lambda s: s not in ("CPU", "GPU")), NOT_A_NUMBER)))
    refused("SamplerEngine", SamplerEngine, optimization_level=data.draw(st.one_of(
        st.integers(-100, -1), st.integers(4, 100), NOT_A_NUMBER, st.booleans())))
    refused("SamplerEngine", SamplerEngine, default_shots=data.draw(BAD_SIZES))
    refused("SamplerEngine", SamplerEngine, sampler=data.draw(NOT_A_NUMBER.filter(
        lambda v: v is not None)))
    refused("SamplerEngine", SamplerEngine, seed=data.draw(st.one_of(st.text(max_size=3),
                                                                     st.floats())))


@settings(max_examples=30)
@given(n=HUGE)
def test_width_guard_refuses_huge_widths(n):
    refused("check_width", check_width, n)


SRC = discrete_source([[0.5, 0.5], [0.9, 0.1]], [1.0, -1.0])


@settings(max_examples=80)
@given(data=st.data(), run=st.sampled_from([per_shot, proportional, neyman]))
def test_schedulers_bad_input_refused(data, run):
    kind = data.draw(st.sampled_from(["alpha_nonfinite", "alpha_sum", "alpha_text", "budget",
                                      "source", "value_range", "seed", "source_output"]))
    alpha, budget, source, kw = [0.5, 0.5], 100, SRC, {}
    if kind == "alpha_nonfinite":
        alpha = poison(np.array(alpha), data)
    elif kind == "alpha_sum":
        alpha = data.draw(st.sampled_from([[0.5, 0.6], [1.5, -0.5], [], [[0.5, 0.5]]]))
    elif kind == "alpha_text":
        alpha = data.draw(NOT_A_NUMBER)
    elif kind == "budget":
        budget = data.draw(st.one_of(BAD_SIZES, st.just(1) if run is neyman else BAD_SIZES))
    elif kind == "source":
        source = data.draw(NOT_A_NUMBER)
    elif kind == "value_range":
        kw["value_range"] = data.draw(st.sampled_from([(1, -1), (0, math.inf), "ab", (math.nan,
                                                                                     1), 3]))
    elif kind == "seed":
        kw["seed"] = data.draw(st.one_of(st.text(min_size=1, max_size=3), st.floats()))
    else:
        out = data.draw(st.sampled_from([None, [[1.0]], [np.full(100, np.nan)] * 2, 3]))
        source = lambda shots, rng: out  # noqa: E731
    refused(run.__name__, run, alpha, budget, source, **kw)


@settings(max_examples=40)
@given(data=st.data())
def test_allocations_and_intervals_bad_input_refused(data):
    sigma = data.draw(st.one_of(NON_FINITE.map(lambda v: [v, 1.0]), st.just([-1.0, 1.0]),
                                st.just([1.0]), NOT_A_NUMBER))
    refused("allocate_neyman", allocate_neyman, [0.5, 0.5], sigma, 10)
    refused("allocate_proportional", allocate_proportional, [0.5, 0.5],
            data.draw(st.one_of(BAD_SIZES, st.just(1))))
    refused("wilson_standard_error", wilson_standard_error, 0.1, data.draw(st.integers(-5, 0)))
