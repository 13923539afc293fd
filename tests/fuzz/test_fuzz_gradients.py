"""Fuzzing ``qdensity.gradients``: parameter shift, commuting-generator and density gradients.

Valid: exact parameter-shift gradients equal central finite differences of exact
``Statevector`` expectations (independent). Invalid input raises ``ValueError``/``TypeError``;
widths beyond the dense limit are refused before any ``2**n`` array is allocated.
"""

from __future__ import annotations

import numpy as np
import pytest
from _fuzz import BAD_SIZES, NOT_A_NUMBER, accepted, poison, refused
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.gradients import commuting_gradient
from qdensity.gradients.density import density_gradient_plan
from qdensity.gradients.shift import parameter_shift_plan
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments

Z0 = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 3)


def _loaded(n: int) -> QuantumCircuit:
    qc = QuantumCircuit(n)
    qc.x(0)
    return qc.compose(pyramid(n))


# ----------------------------------------------------------------------------- found case
def test_found_commuting_gradient_at_32_qubits_allocates_no_dense_table():
    """Found: the 32-qubit commuting gradient tried to allocate a (2**32, 16) table. Its
    estimators now read the measured bits (issue "Scale"), so the plan builds; the dense path
    (exact probabilities) is refused by the shared width guard before allocating."""
    model = DensityQNN(by_moments(round_robin(32)).sub_unitaries[:2],
                       encoding=Encoding.unary(32))
    plan = density_gradient_plan(model, np.ones((1, 32)), method="commuting", shots=10)
    assert {job.circuit.num_qubits for job in plan.jobs} == {32}
    with pytest.raises(ValueError, match=r"at most 24 qubits"):
        plan.run(ExactEngine())


# ----------------------------------------------------------------------------- valid input
@settings(max_examples=6)
@given(seed=st.integers(0, 2**16))
def test_parameter_shift_matches_finite_differences(seed):
    accepted("parameter_shift_plan")
    circ = _loaded(3)
    theta = np.random.default_rng(seed).uniform(-np.pi, np.pi, circ.num_parameters)
    grad = parameter_shift_plan(circ, Z0, theta).run(ExactEngine()).value[0]

    def f(t):
        return Statevector(circ.assign_parameters(t)).expectation_value(Z0).real

    h = 1e-5
    fd = [(f(theta + h * e) - f(theta - h * e)) / (2 * h) for e in np.eye(theta.size)]
    np.testing.assert_allclose(grad, fd, atol=1e-6)


# ----------------------------------------------------------------------------- invalid input
@settings(max_examples=50)
@given(data=st.data())
def test_gradient_plans_bad_input_refused(data):
    circ = _loaded(3)
    P = circ.num_parameters
    kind = data.draw(st.sampled_from(["nonfinite", "shape", "text", "shots", "rule",
                                      "observable", "circuit"]))
    vals, shots, rule, obs, c = np.zeros(P), None, "four_term", Z0, circ
    if kind == "nonfinite":
        vals = poison(vals, data)
    elif kind == "shape":
        vals = np.zeros(data.draw(st.sampled_from([(P + 1,), (2, P - 1), (0, P)])))
    elif kind == "text":
        vals = data.draw(NOT_A_NUMBER.filter(lambda v: v is not None))
    elif kind == "shots":
        shots = data.draw(BAD_SIZES.filter(lambda v: v is not None))
    elif kind == "rule":
        rule = data.draw(st.text(max_size=6))
    elif kind == "observable":
        obs = data.draw(st.sampled_from(["ZZ", "Q", 3.5, SparsePauliOp("ZII", 1j)]))
    else:
        c = data.draw(NOT_A_NUMBER)
    refused("parameter_shift_plan", parameter_shift_plan, c, obs, vals, shots=shots,
            rbs_rule=rule)
    if kind in ("observable", "circuit"):
        refused("commuting_gradient", commuting_gradient, c, obs)


@settings(max_examples=30)
@given(data=st.data())
def test_density_gradient_plan_bad_input_refused(data):
    model = DensityQNN(by_moments(round_robin(4)).sub_unitaries, encoding=Encoding.unary(4),
                       readout="unary_probabilities")
    kind = data.draw(st.sampled_from(["method", "shots", "X"]))
    X, method, shots = np.ones((1, 4)), "auto", None
    if kind == "method":
        method = data.draw(st.text(max_size=6))
    elif kind == "shots":
        shots = data.draw(BAD_SIZES.filter(lambda v: v is not None))
    else:
        X = data.draw(st.sampled_from([np.ones((1, 3)), np.full((1, 4), np.nan), "abcd",
                                       np.zeros((0, 4)), np.zeros((1, 4))]))
    refused("density_gradient_plan", lambda: density_gradient_plan(
        model, X, method=method, shots=shots).run(ExactEngine()))
