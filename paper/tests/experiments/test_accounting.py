"""Circuits per data point, broken down, against the ledger of one real sampled training step:
a QuantumLayer with input gradients on Aer's SamplerV2 (the density gradient plan, forward +
parameter gradients, and the input-gradient plan on the loader's angles, which a trainable
layer in front of the loader needs), every circuit on the ledger; the loader-angle shift
circuits against finite differences of the exact unary probabilities."""

from __future__ import annotations

import numpy as np
import pytest

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.loaders import loader_angles, unary_loader_template
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.shift import parameter_shift_plan
from qdensity.learning.layer import QuantumLayer
from qdensity.models.decompositions import odd_even
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import SoftmaxMixture
from qdensity_paper._accounting import breakdown_metrics, circuit_breakdown

N = 4


def _models():
    enc = Encoding.unary(N)
    dec = odd_even(pyramid(N))
    return {
        "pure": (DensityQNN([pyramid(N)], encoding=enc, readout="unary_probabilities", seed=1),
                 "shift"),
        "odd_even": (DensityQNN(dec.sub_unitaries, SoftmaxMixture(2), encoding=enc,
                                readout="unary_probabilities", seed=2), "commuting"),
    }


def _input_plan(model, k, X, shots):
    loader = unary_loader_template(N, parameter_prefix="load")
    circuit = loader.compose(model.sub_unitaries[k])
    angles = loader_angles(X)
    theta = model.rows(k, X)[:, -model.sub_unitaries[k].num_parameters:]
    values = np.hstack([angles, theta]) if theta.size else angles
    return circuit, parameter_shift_plan(circuit, None, values, parameters=list(loader.parameters),
                                         shots=shots)


@pytest.mark.parametrize("name", ["pure", "odd_even"])
def test_breakdown_matches_the_ledger_of_a_sampled_step(name):
    model, method = _models()[name]
    X = np.random.default_rng(0).uniform(0.1, 1.0, (3, N))
    breakdown = circuit_breakdown(model, X[:1], method=method, input_gradients=True)
    engine = SamplerEngine(seed=11)
    layer = QuantumLayer(model, engine, shots=64, gradient=method, input_gradients=True)
    layer.forward(X)
    assert layer.backward(np.ones((len(X), N))).shape == X.shape  # d L / d x came back
    rows = len(X)
    spent = engine.ledger.by_label()
    inputs = [spent[f"input_gradient_k{k}"][0] for k in range(model.num_subunitaries)]
    assert inputs == [rows * c for c in breakdown["input_gradients"]]
    assert engine.ledger.total_circuits - sum(inputs) == rows * (
        breakdown["forward"] + sum(breakdown["parameter_gradients"]))
    assert engine.ledger.total_circuits == rows * breakdown["per_point"]
    assert engine.ledger.total_shots == 64 * rows * breakdown["per_point"]
    # independent counts: four-term rule per RBS angle, per loader angle, one forward
    gates, K = N * (N - 1) // 2, model.num_subunitaries
    expected_params = 4 * gates if name == "pure" else K  # one commuting circuit each
    assert sum(breakdown["parameter_gradients"]) == expected_params
    assert breakdown["input_gradients"] == [4 * (N - 1)] * K
    flat = breakdown_metrics(name, breakdown)
    assert flat[f"{name}/circuits_per_row"] == breakdown["per_point"]


def test_input_gradient_circuits_compute_the_input_gradient():
    model, _ = _models()["odd_even"]
    X = np.random.default_rng(1).uniform(0.1, 1.0, (2, N))
    circuit, plan = _input_plan(model, 0, X, None)
    grad = np.asarray(plan.run(ExactEngine()).value)  # (B, 2^N, N - 1)
    loader = unary_loader_template(N, parameter_prefix="load")
    angles = loader_angles(X)
    theta = model.rows(0, X)[:, N - 1:]
    eps = 1e-6
    assert grad.shape == (len(X), 2**N, N - 1)
    from qiskit.quantum_info import Statevector

    def p_of(a, b):
        bound = circuit.assign_parameters(np.concatenate([a, theta[b]]))
        return Statevector(bound).probabilities()

    for b in range(len(X)):
        for j in range(len(loader.parameters)):
            up, down = angles[b].copy(), angles[b].copy()
            up[j] += eps
            down[j] -= eps
            fd = (p_of(up, b) - p_of(down, b)) / (2 * eps)
            np.testing.assert_allclose(grad[b, :, j], fd, atol=1e-6)
