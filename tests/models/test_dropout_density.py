"""Dropout for every density model: the train phase from shots of the randomised preparation,
the eval phase exact, against independent oracles (Qiskit statevectors of each sub-unitary for
the mixture; central finite differences of the exact squared error for the gradient's mean)."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.execution import ShotLedger
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import SoftmaxMixture


def _sub(name: str) -> QuantumCircuit:
    t = ParameterVector(name, 4)
    x = ParameterVector("x", 2)
    qc = QuantumCircuit(2)
    qc.ry(x[0], 0)
    qc.ry(x[1], 1)
    qc.ry(t[0], 0)
    qc.rz(t[1], 1)
    qc.cx(0, 1)
    qc.ry(t[2], 1)
    qc.rx(t[3], 0)
    return qc


def _model(observable="ZI", K=2):
    model = DensityQNN([_sub(f"t{k}") for k in range(K)],
                       SoftmaxMixture(logits=np.array([0.3, -0.2, 0.5][:K])),
                       observable=SparsePauliOp(observable), seed=4)
    return model


def _mse(model, X, y):
    return float(np.mean((model.predict(X) - y) ** 2))


def _finite_difference(model, X, y, h=1e-6):
    theta, mix = model.theta.copy(), model.mixture.params.copy()
    g_theta, g_mix = np.zeros_like(theta), np.zeros_like(mix)
    for i in range(theta.size):
        for s in (1, -1):
            t = theta.copy()
            t[i] += s * h
            model.set_params(theta=t)
            g_theta[i] += s * _mse(model, X, y) / (2 * h)
    model.set_params(theta=theta)
    for i in range(mix.size):
        for s in (1, -1):
            m = mix.copy()
            m[i] += s * h
            model.set_params(mixture=m)
            g_mix[i] += s * _mse(model, X, y) / (2 * h)
    model.set_params(mixture=mix)
    return np.concatenate([g_theta, g_mix])


X = np.array([[0.3, -0.8], [1.1, 0.4], [-0.5, 0.9]])
Y = np.array([0.2, -0.3, 0.5])


def test_prediction_is_the_exact_mixture_of_statevectors():
    """eval().predict equals sum_k alpha_k <O>_k from Qiskit statevectors of each bound
    sub-unitary (the deterministic circuit's reduced state is the mixture, Fig. 1b)."""
    model = _model().eval()
    alpha = model.alpha(X)[0]
    obs = SparsePauliOp("ZI")
    for x, got in zip(X, model.predict(X), strict=True):
        want = 0.0
        for k, sub in enumerate(model.sub_unitaries):
            values = dict(zip(model.parameters, model.theta, strict=True))
            values.update({p: x[p.index] for p in sub.parameters if p.name.startswith("x[")})
            want += alpha[k] * Statevector(sub.assign_parameters(
                {p: values[p] for p in sub.parameters})).expectation_value(obs).real
        assert got == pytest.approx(want, abs=1e-10)


@pytest.mark.parametrize("observable", ["ZI", "XZ"])
def test_randomised_gradient_is_unbiased(observable):
    """The mean of 200 seeds' train-mode gradients lies within 5 standard errors of the
    finite-difference gradient in each of its 10 components (a false failure about
    10 x 6e-7; 1e-9 beside it for the components the observable does not see, exactly 0);
    eval mode gives the finite-difference gradient itself."""
    model = _model(observable)
    exact = _finite_difference(model, X, Y)
    model.train()
    draws = []
    for s in range(200):
        _, g = model.randomised_loss_and_grad(X, Y, 30, seed=s)
        draws.append(np.concatenate([g["theta"], g["mixture"]]))
    draws = np.array(draws)
    mean, se = draws.mean(axis=0), draws.std(axis=0, ddof=1) / np.sqrt(len(draws))
    assert np.sum(se > 0) >= 6  # the shots do vary the estimate
    assert np.all(np.abs(mean - exact) < 5 * se + 1e-9), np.abs(mean - exact) / se
    loss, g = model.eval().randomised_loss_and_grad(X, Y, 30)
    assert loss == pytest.approx(_mse(model, X, Y))
    assert np.allclose(np.concatenate([g["theta"], g["mixture"]]), exact, atol=1e-6)


def test_randomised_outputs_keep_the_mixture_mean_and_the_ledger():
    """Train-mode losses from 2,000 shots a point: their mean over 200 seeds is the exact
    squared error plus the shot variance term, and the ledger holds every shot drawn."""
    model = _model().train()
    ledger = ShotLedger()
    model.randomised_loss_and_grad(X, Y, 50, seed=1, ledger=ledger)
    shots = ledger.by_label()
    for label in ("forward", "gradient", "mixture"):
        assert sum(shots[f"{label}_k{k}"][1] for k in range(2)) == 3 * 50
    a = model.randomised_loss_and_grad(X, Y, 50, seed=5)
    b = model.randomised_loss_and_grad(X, Y, 50, seed=5)
    assert a[0] == b[0] and np.array_equal(a[1]["theta"], b[1]["theta"])
    # E[(f_hat - y)^2] = (f - y)^2 + Var(f_hat), Var(f_hat) = (1 - f^2) / S for +-1 outcomes
    S = 2000
    f = model.predict(X)
    want = float(np.mean((f - Y) ** 2 + (1 - f**2) / S))
    losses = np.array([model.randomised_loss_and_grad(X, Y, S, seed=s)[0] for s in range(200)])
    se = losses.std(ddof=1) / np.sqrt(losses.size)
    assert abs(losses.mean() - want) < 5 * se


def test_unary_probability_models_train_by_the_randomised_preparation():
    """A Hamming-weight-preserving density model read out as unary probabilities: the mean of
    300 seeds' gradients within 5 standard errors of finite differences (each component)."""
    from qdensity.circuits.ansatze import pyramid
    from qdensity.models.decompositions import by_moments

    dec = by_moments(pyramid(3))
    model = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(3),
                       readout="unary_probabilities", seed=2)
    Xu = np.array([[1.0, 2.0, 0.5], [0.3, -1.0, 2.0]])
    Yu = np.array([[0.2, 0.5, 0.3], [0.6, 0.1, 0.3]])
    h = 1e-6
    exact = np.zeros(model.num_parameters)
    theta = model.theta.copy()
    for i in range(theta.size):
        for s in (1, -1):
            t = theta.copy()
            t[i] += s * h
            model.set_params(theta=t)
            exact[i] += s * np.sum((model.predict(Xu) - Yu) ** 2) / Xu.shape[0] / (2 * h)
    model.set_params(theta=theta)
    draws = np.array([model.train().randomised_loss_and_grad(Xu, Yu, 40, seed=s)[1]["theta"]
                      for s in range(300)])
    mean, se = draws.mean(axis=0), draws.std(axis=0, ddof=1) / np.sqrt(len(draws))
    assert np.all(np.abs(mean - exact) < 5 * se + 1e-9), np.abs(mean - exact) / se


def test_bad_input():
    model = _model()
    with pytest.raises(ValueError, match="shots"):
        model.randomised_loss_and_grad(X, Y, 0)
    with pytest.raises(ValueError, match="y must have shape"):
        model.randomised_loss_and_grad(X, Y[:2], 10)
    two_terms = DensityQNN([_sub("a"), _sub("b")], observable=SparsePauliOp(["ZI", "IZ"]))
    with pytest.raises(ValueError, match="one Pauli term"):
        two_terms.randomised_loss_and_grad(X, Y, 10)
