"""Exact training of every model family (issue 16): adjoint gradients of density models against
finite differences of Aer values and against parameter-shift plans, engines and compiled
circuits kept for a model's lifetime (counted over 10-step fits), QCNN trains, warm start."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp

import qdensity.execution.unary as unary_module
from qdensity.circuits.ansatze import (
    equivariant_commuting,
    equivariant_noncommuting,
    hardware_efficient,
    qcnn,
    reuploading,
    round_robin,
)
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.statevector.adjoint import AdjointEngine
from qdensity.learning.training import QNNRegressor, QuantumLayer
from qdensity.models import (
    DensityQNN,
    Encoding,
    GatedMixture,
    SoftmaxMixture,
    by_moments,
    independent,
    warm_start,
)
from qdensity.models.exact import engines_of

RNG = np.random.default_rng(16)


def _equivariant_density(n=3, seed=0, mixture=None):
    subs = independent([equivariant_commuting(n, "X", 2), equivariant_commuting(n, "Y", 2)])
    obs = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    return DensityQNN(subs.sub_unitaries, mixture or SoftmaxMixture(alpha=[0.3, 0.7]),
                      encoding=Encoding.angle(n), observable=obs, seed=seed)


def _loss(model, X, y, method="aer"):
    return 0.5 * np.sum((model.predict(X, method=method) - y) ** 2)


def _fd_grads(model, X, y, eps=1e-6):
    theta0, mix0 = model.theta.copy(), model.mixture.params.copy()
    g_theta, g_mix = np.zeros_like(theta0), np.zeros_like(mix0)
    for i in range(theta0.size):
        for sgn in (1, -1):
            t = theta0.copy()
            t[i] += sgn * eps
            model.set_params(t)
            g_theta[i] += sgn * _loss(model, X, y) / (2 * eps)
    model.set_params(theta0)
    for i in range(mix0.size):
        for sgn in (1, -1):
            m = mix0.copy()
            m[i] += sgn * eps
            model.set_params(mixture=m)
            g_mix[i] += sgn * _loss(model, X, y) / (2 * eps)
    model.set_params(theta0, mix0)
    return g_theta, g_mix


def _layer_grads(layer, X, y):
    out = layer.forward(X)
    return out, layer.backward(out - y[:, None])


def test_density_mixture_gradients_match_finite_differences_of_aer():
    model = _equivariant_density()
    X = RNG.uniform(-1, 1, (4, 3))
    y = RNG.uniform(-1, 1, 4)
    layer = QuantumLayer(model)
    assert layer.adjoint and not layer.analytic
    out, _ = _layer_grads(layer, X, y)
    np.testing.assert_allclose(out[:, 0], model.predict(X, method="aer"), atol=1e-9)
    g_theta, g_mix = _fd_grads(model, X, y)
    np.testing.assert_allclose(layer.grads["theta"], g_theta, atol=1e-6)
    np.testing.assert_allclose(layer.grads["mixture"], g_mix, atol=1e-6)


@pytest.mark.parametrize("family", ["qcnn", "noncommuting", "hardware_efficient", "gated"])
def test_adjoint_layer_matches_parameter_shift_plans(family):
    n = 4
    if family == "qcnn":
        subs = [qcnn(n)]
        obs = SparsePauliOp("ZIII")
    elif family == "noncommuting":
        subs = independent([equivariant_noncommuting(n, 1), equivariant_noncommuting(n, 1)]
                           ).sub_unitaries
        obs = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    else:
        subs = by_moments(hardware_efficient(n, 2, ("ry", "rz")), 1).sub_unitaries
        obs = SparsePauliOp("ZZII")
    mixture = GatedMixture(n, len(subs), seed=1) if family == "gated" else None
    model = DensityQNN(subs, mixture, encoding=Encoding.angle(n), observable=obs, seed=2)
    X = RNG.uniform(-1, 1, (3, n))
    y = RNG.uniform(-1, 1, 3)
    adjoint = QuantumLayer(model)
    _layer_grads(adjoint, X, y)
    shift = QuantumLayer(model, ExactEngine(), gradient="shift")
    _layer_grads(shift, X, y)
    for key in ("theta", "mixture"):
        np.testing.assert_allclose(adjoint.grads[key], shift.grads[key], atol=1e-9)


def test_reuploading_input_gradients_match_finite_differences():
    model = DensityQNN([reuploading(3)], seed=3)
    X = RNG.uniform(-1, 1, (5, 1))
    y = RNG.uniform(-1, 1, 5)
    layer = QuantumLayer(model)
    _, gx = _layer_grads(layer, X, y)
    eps = 1e-6
    fd = np.array([(_loss(model, X + eps * e, y) - _loss(model, X - eps * e, y)) / (2 * eps)
                   for e in np.eye(5)[:, :, None]])
    np.testing.assert_allclose(gx[:, 0], fd, atol=1e-7)


def _fit(layer, X, y, steps, lr=0.1, batch=4):
    """A plain mini-batch gradient descent on the squared error (the estimators' loop)."""
    losses = []
    for step in range(steps):
        idx = np.arange(step * batch, (step + 1) * batch) % X.shape[0]
        out = layer.forward(X[idx])
        losses.append(0.5 * np.mean((out[:, 0] - y[idx]) ** 2))
        layer.backward((out[:, 0:1] - y[idx, None]) / len(idx))
        theta = layer.model.theta - lr * layer.grads["theta"]
        mix = layer.model.mixture.params - lr * layer.grads["mixture"]
        layer.set_params(theta, mix)
    return np.array(losses)


def test_compilations_do_not_grow_over_a_ten_step_fit():
    model = _equivariant_density(seed=4)
    X = RNG.uniform(-1, 1, (8, 3))
    y = np.tanh(X.sum(axis=1))
    layer = QuantumLayer(model)
    _fit(layer, X, y, 1)
    engine = engines_of(model).adjoint
    assert engine.compile_count == model.num_subunitaries
    _fit(layer, X, y, 10)
    assert engine.compile_count == model.num_subunitaries
    assert QuantumLayer(model).forward(X[:2]).shape == (2, 1)  # a new layer, the same engine
    assert engines_of(model).adjoint is engine and engine.compile_count == 2


@pytest.mark.parametrize("kind", ["aer_exact", "sampler"])
def test_transpilations_do_not_grow_over_a_ten_step_fit(kind):
    model = DensityQNN([qcnn(3)], encoding=Encoding.angle(3), observable=SparsePauliOp("ZII"),
                       seed=5)
    X = RNG.uniform(-1, 1, (6, 3))
    y = RNG.uniform(-1, 1, 6)
    if kind == "aer_exact":
        engine, shots = ExactEngine(), None
    else:
        engine, shots = SamplerEngine(seed=7), 64
    layer = QuantumLayer(model, engine, shots, gradient="shift")
    _fit(layer, X, y, 1, batch=2)
    after_one = engine.transpile_count
    assert after_one >= 1
    _fit(layer, X, y, 9, batch=2)
    assert engine.transpile_count == after_one


def test_estimator_fit_keeps_the_models_engine():
    model = _equivariant_density(seed=6)
    X = RNG.uniform(-1, 1, (12, 3))
    y = np.tanh(X.sum(axis=1))
    theta = model.theta.copy()
    est = QNNRegressor(model, epochs=1, batch_size=3, max_steps=10, verbose=False, seed=0)
    est.fit(X, y)  # fit trains a copy of the template (scikit-learn's rule), never the template
    np.testing.assert_array_equal(model.theta, theta)
    engine = engines_of(est.model_).adjoint
    assert engine.compile_count == 2  # compiled once for the 10 steps, not once per step
    est.predict(X)
    assert engines_of(est.model_).adjoint is engine and engine.compile_count == 2


def test_unary_models_compile_their_circuits_once(monkeypatch):
    calls = []
    real = unary_module.compile_unary

    def counting(circuit):
        if not isinstance(circuit, unary_module.UnaryCircuit):  # a real compilation
            calls.append(circuit)
        return real(circuit)

    monkeypatch.setattr(unary_module, "compile_unary", counting)
    dec = by_moments(round_robin(4))
    model = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(4),
                       readout="unary_probabilities", seed=8)
    X = RNG.uniform(0.1, 1, (8, 4))
    layer = QuantumLayer(model)
    assert layer.analytic
    for _ in range(10):
        out = layer.forward(X)
        layer.backward(np.ones_like(out))
        model.predict(X)
    assert len(calls) == model.num_subunitaries


def test_qcnn_trains_through_the_adjoint_engine_and_through_sampled_shift_plans():
    model = DensityQNN([qcnn(4)], encoding=Encoding.angle(4), observable=SparsePauliOp("ZIII"),
                       seed=9)
    X = RNG.uniform(-1, 1, (8, 4))
    y = np.where(X[:, 0] > 0, 0.5, -0.5)
    before = _loss(model, X, y, "statevector")
    losses = _fit(QuantumLayer(model), X, y, 30, lr=0.3, batch=8)
    assert _loss(model, X, y, "statevector") < 0.8 * before
    assert losses[-1] < losses[0]
    layer = QuantumLayer(model, SamplerEngine(seed=1), shots=256, gradient="shift")
    _fit(layer, X, y, 2, batch=2)
    assert layer.shots_spent > 0 and np.all(np.isfinite(layer.grads["theta"]))


def test_adjoint_engine_instance_and_outputs_agree_with_aer():
    model = _equivariant_density(seed=10)
    X = RNG.uniform(-1, 1, (3, 3))
    np.testing.assert_allclose(model.expert_outputs(X), model.expert_outputs(X, method="aer"),
                               atol=1e-9)
    own = QuantumLayer(model)
    given = QuantumLayer(model, AdjointEngine())
    np.testing.assert_allclose(own.forward(X), given.forward(X), atol=1e-14)
    with pytest.raises(ValueError, match="'auto', 'unary', 'statevector' or 'aer'"):
        model.expert_outputs(X, method="gpu")
    with pytest.raises(ValueError, match="engine must be 'exact' or an AdjointEngine, ExactEngine"):
        QuantumLayer(model, engine="fast")


# ---------------------------------------------------------------------- warm start
def test_warm_start_outputs_are_the_mixture_of_the_trained_models():
    n = 3
    obs = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    trained = []
    for k, pauli in enumerate("XY"):
        m = DensityQNN([equivariant_commuting(n, pauli, 2)], encoding=Encoding.angle(n),
                       observable=obs, seed=k)
        X = RNG.uniform(-1, 1, (8, n))
        _fit(QuantumLayer(m), X, np.tanh(X.sum(axis=1)), 3)
        trained.append(m)
    X = RNG.uniform(-1, 1, (5, n))
    model = warm_start(trained, [0.99, 0.01])
    expected = 0.99 * trained[0].predict(X) + 0.01 * trained[1].predict(X)
    np.testing.assert_allclose(model.predict(X, method="aer"), expected, atol=1e-9)
    np.testing.assert_allclose(model.alpha()[0], [0.99, 0.01])
    # the same circuit trained twice shares parameter objects: the warm start separates them
    twin = DensityQNN([trained[0].sub_unitaries[0]], encoding=Encoding.angle(n),
                      observable=obs, seed=5)
    both = warm_start([trained[0], twin], [0.5, 0.5], mixture="fixed")
    assert both.num_parameters == 2 * trained[0].num_parameters
    np.testing.assert_allclose(both.predict(X),
                               0.5 * trained[0].predict(X) + 0.5 * twin.predict(X), atol=1e-12)
    losses = _fit(QuantumLayer(model), X, np.tanh(X.sum(axis=1)), 5, batch=5)
    assert np.all(np.isfinite(losses))


def test_warm_start_refuses_bad_input():
    a = DensityQNN([reuploading(1, parameter_prefix="a")])
    b = DensityQNN([reuploading(1, parameter_prefix="b")])
    with pytest.raises(ValueError, match="sub_models must be a list or tuple of 1 to"):
        warm_start([], [])
    with pytest.raises(ValueError, match="one weight per sub-model"):
        warm_start([a, b], [1.0])
    with pytest.raises(ValueError, match="positive"):
        warm_start([a, b], [1.0, 0.0])
    with pytest.raises(ValueError, match="mixture must be one of"):
        warm_start([a, b], [0.5, 0.5], mixture="gated")
    with pytest.raises(ValueError, match="K = 2"):
        warm_start([DensityQNN([reuploading(1), reuploading(1, parameter_prefix="c")])], [1.0])
    with pytest.raises(TypeError, match="DensityQNN"):
        warm_start([reuploading(1)], [1.0])
    wide = DensityQNN([hardware_efficient(2, 1)])
    with pytest.raises(ValueError, match="width"):
        warm_start([a, wide], [0.5, 0.5])
