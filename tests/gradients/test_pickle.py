"""Models and plans pickle (joblib, multiprocessing and optuna workers ship them): a plan run
after a round trip gives the same answer as the original, against the exact engine."""

import pickle

import numpy as np
import pytest

from qdensity.circuits.ansatze import hardware_efficient, round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.gradients.density import density_gradient_plan
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments, copies
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture


def _models():
    dec = by_moments(round_robin(4))
    unary = DensityQNN(dec.sub_unitaries, GatedMixture(4, dec.num_subunitaries, seed=1),
                       encoding=Encoding.unary(4), readout="unary_probabilities", seed=0)
    angle = DensityQNN(copies(hardware_efficient(3, 1), 2).sub_unitaries, SoftmaxMixture(2),
                       encoding=Encoding.angle(3), seed=2)
    return unary, angle


@pytest.mark.parametrize("method", ["shift", "commuting"])
def test_models_and_gradient_plans_round_trip(method):
    X = np.random.default_rng(0).normal(size=(2, 4))
    unary, angle = _models()
    for model, data in ((unary, X), (angle, X[:, :3])):
        back = pickle.loads(pickle.dumps(model))
        np.testing.assert_array_equal(back.predict(data), model.predict(data))
        if method == "commuting" and model is angle:
            continue  # hardware-efficient circuits have no commuting-generator gradient
        plan = density_gradient_plan(model, data, method=method)
        a = plan.run(ExactEngine())
        b = pickle.loads(pickle.dumps(plan)).run(ExactEngine())
        np.testing.assert_array_equal(b.outputs, a.outputs)
        for ja, jb in zip(a.jacobians, b.jacobians, strict=True):
            np.testing.assert_array_equal(jb, ja)
