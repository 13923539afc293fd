"""The paper's Fig. 6b model (a density QNN of single-qubit re-uploading sub-unitaries, data
entering through ``x[0]`` and no :class:`Encoding`) trains through every public path: the
scikit-learn estimators, the quantum layer, the PyTorch layer and the ``reuploading``
experiment. Oracles: finite differences of exact predictions, and Qiskit statevectors."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import reuploading
from qdensity.learning.estimators import QNNRegressor
from qdensity.learning.layer import QuantumLayer
from qdensity.models.density import DensityQNN
from qdensity.models.mixtures import SoftmaxMixture
from qdensity.models.single_qubit import SingleQubitReuploading

X = np.linspace(-1.0, 1.0, 8)[:, None]
Y = 2 * X[:, 0] ** 2 - 1  # T_2


def _model(layers: int = 2, seed: int = 1) -> DensityQNN:
    subs = [reuploading(layers), reuploading(layers, parameter_prefix="φ")]
    return DensityQNN(subs, SoftmaxMixture(2), readout="observable", seed=seed)


def _fd_theta(model: DensityQNN, weights: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Central differences of ``sum_i w_i f(x_i)`` with respect to every angle."""
    theta = model.theta.copy()
    out = np.empty(theta.size)
    for j in range(theta.size):
        e = np.zeros_like(theta)
        e[j] = eps
        plus = model.predict(X, theta + e) @ weights
        minus = model.predict(X, theta - e) @ weights
        out[j] = (plus - minus) / (2 * eps)
    return out


def test_model_counts_the_uploaded_feature_and_matches_statevectors():
    model = _model()
    assert model.num_features == 1
    with pytest.raises(ValueError, match="X must have shape"):
        model.predict(np.zeros((2, 3)))
    # oracle: each sub-unitary bound and simulated by Qiskit, mixed by alpha
    x = 0.3
    f = []
    for sub in model.sub_unitaries:
        bind = {p: (x if p.name == "x[0]" else model.theta[model.parameters.index(p)])
                for p in sub.parameters}
        bound = sub.assign_parameters(bind)
        f.append(Statevector(bound).expectation_value(SparsePauliOp("Z")).real)
    want = model.alpha()[0] @ np.array(f)
    assert model.predict([[x]])[0] == pytest.approx(want, abs=1e-12)


def test_estimator_trains_the_reuploading_model_and_its_loss_falls():
    reg = QNNRegressor(model=_model(), epochs=12, batch_size=8, learning_rate=0.1, post=None,
                       verbose=False).fit(X, Y)
    losses = [r["train_loss"] for r in reg.history_.epochs]
    assert len(losses) == 12
    assert losses[-1] < 0.5 * losses[0]
    assert reg.predict(X).shape == (8,)
    with pytest.raises(ValueError, match="X has 2 features but the model template takes 1"):
        QNNRegressor(model=_model(), epochs=1, verbose=False).fit(np.zeros((4, 2)), np.zeros(4))


def test_quantum_layer_gradient_matches_finite_differences():
    model = _model(layers=3, seed=4)
    layer = QuantumLayer(model)
    weights = np.random.default_rng(2).normal(size=X.shape[0])
    out = layer.forward(X)
    assert out.shape == (8, 1)
    layer.backward(weights[:, None])
    np.testing.assert_allclose(layer.grads["theta"], _fd_theta(model, weights), atol=1e-7)


def test_torch_layer_gradient_matches_finite_differences():
    torch = pytest.importorskip("torch", reason="the torch extra: pip install 'qdensity[torch]'")
    from qdensity.learning.torch import DensityQNNLayer

    model = _model(layers=2, seed=5)
    layer = DensityQNNLayer(model)
    weights = np.random.default_rng(3).normal(size=X.shape[0])
    out = layer(torch.tensor(X, dtype=torch.float64))
    assert tuple(out.shape) == (8, 1)
    (out[:, 0] @ torch.tensor(weights)).backward()
    np.testing.assert_allclose(layer.theta.grad.numpy(), _fd_theta(model, weights), atol=1e-7)


def test_experiment_model_is_the_circuit_model_and_trains():
    """The ``reuploading`` experiment trains :class:`SingleQubitReuploading`; it computes the
    same function as the DensityQNN of :func:`reuploading` circuits, and Adam lowers its MSE."""
    from qdensity_paper.reuploading import _train

    sq = SingleQubitReuploading(2, 2, seed=0)
    model = _model()
    # DensityQNN parameters are sorted by name per vector: θ[0..5] then φ[0..5]
    model.theta = np.concatenate([sq.theta[0].ravel(), sq.theta[1].ravel()])
    model.mixture.params = sq.logits.copy()
    np.testing.assert_allclose(sq.predict(X), model.predict(X), atol=1e-12)
    cfg = {"learning_rate": 0.05, "epochs": 20, "batch_size": 4, "curve_points": 2,
           "shots_per_circuit": 1}
    before = sq.mse(X, Y)
    res = _train(sq, (X, X, Y, Y), cfg, np.random.default_rng(0), record=False)
    assert res["train_mse"] < 0.8 * before
