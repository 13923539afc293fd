"""Everything a worker receives travels by the standard ``pickle``: models, estimators, plans,
targets, engines (SamplerEngine with its target), results. Each object, pickled and loaded,
gives what an independent computation gives (a statevector, the original object's answers with
the same seeds)."""

from __future__ import annotations

import pickle

import numpy as np
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import hardware_efficient, round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import expectation_plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.targets import get_target
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN, Encoding
from qdensity_paper.results import ExperimentResult


def _again(obj):
    return pickle.loads(pickle.dumps(obj))


def _plan():
    qc = hardware_efficient(3, 1)
    values = np.random.default_rng(0).uniform(-np.pi, np.pi, (4, qc.num_parameters))
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("X", [2], 0.5)], 3)
    exact = [Statevector(qc.assign_parameters(v)).expectation_value(obs).real for v in values]
    return qc, values, obs, np.array(exact)


def test_a_plan_and_the_exact_engine_pickle():
    qc, values, obs, exact = _plan()
    plan = _again(expectation_plan(qc, obs, values))
    got = np.asarray(plan.run(_again(ExactEngine())).value)
    np.testing.assert_allclose(got, exact, atol=1e-10)


def test_a_density_model_pickles():
    n = 4
    dec = by_moments(round_robin(n))
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN(dec.sub_unitaries, np.full(dec.num_subunitaries, 1 / dec.num_subunitaries),
                       encoding=Encoding.unary(n), observable=obs, seed=3)
    X = np.random.default_rng(1).normal(size=(5, n))
    np.testing.assert_array_equal(_again(model).predict(X), model.predict(X))


def test_a_fitted_estimator_pickles():
    from sklearn.datasets import load_iris

    from qdensity.learning.estimators import QNNClassifier

    X, y = load_iris(return_X_y=True)
    clf = QNNClassifier(num_qubits=3, epochs=1, verbose=False, seed=0).fit(X, y)
    np.testing.assert_array_equal(_again(clf).predict(X), clf.predict(X))
    assert _again(QNNClassifier(epochs=2)).get_params() == QNNClassifier(epochs=2).get_params()


def test_a_target_pickles():
    target = get_target("heavy_hex", 4, seed=0)
    back = _again(target)
    assert back.label == target.label
    assert back.num_qubits == target.num_qubits


def test_a_result_pickles():
    res = ExperimentResult(name="x", mode="quick", config={"a": 1}, seeds=[0, 1],
                           per_seed=[{"m": 0.5, "worker": "w"}, {"m": 0.7, "worker": "w"}])
    assert _again(res).to_dict() == res.to_dict()


def test_a_sampler_engine_with_its_target_pickles():
    """The same seed after the round trip: the same counts, so the same estimates."""
    qc, values, obs, exact = _plan()
    engine = SamplerEngine(target=get_target("heavy_hex", 3, seed=0), seed=3, progress=False)
    back = _again(engine)
    plan = expectation_plan(qc, obs, values, shots=4000)
    a, b = plan.run(engine), plan.run(back)
    np.testing.assert_array_equal(np.asarray(a.value), np.asarray(b.value))
    assert np.all(np.abs(np.asarray(a.value) - exact) < 0.5)  # noisy, but near the exact values
