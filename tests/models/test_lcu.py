"""The LCU model against the gate-level LCU circuit (post-selected statevector and success
probability, docs/design.md, "Oracles") and its gradients against central finite differences."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.circuits.preparation import lcu_postselected_state, lcu_success_probability
from qdensity.models import DensityQNN, Encoding, FixedMixture, GatedMixture, SoftmaxMixture
from qdensity.models.decompositions import by_moments, trainable_parameters
from qdensity.models.lcu import LCUQNN

RNG = np.random.default_rng(21)


def _bound_subs(model):
    out = []
    for k, sub in enumerate(model.density.sub_unitaries):
        idx = model.density.subunitary_parameter_indices(k)
        out.append(sub.assign_parameters(dict(zip(trainable_parameters(sub), model.theta[idx],
                                                  strict=True))))
    return out


@pytest.mark.parametrize("mixture", ["softmax", "gated"])
def test_predict_and_success_match_the_lcu_circuit(mixture):
    n = 4
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    mix = SoftmaxMixture(logits=RNG.normal(size=K)) if mixture == "softmax" else \
        GatedMixture(n, K, seed=3)
    model = LCUQNN(dec.sub_unitaries, mix, seed=5)
    X = RNG.normal(size=(3, n))
    P = model.predict(X)
    succ = model.success_probability(X)
    alpha = model.mixture.alpha(X)
    subs = _bound_subs(model)
    for b, x in enumerate(X):
        loader = unary_loader(x)
        state = lcu_postselected_state(subs, alpha[b], loader=loader)
        probs = np.abs(np.asarray(state.data)) ** 2
        np.testing.assert_allclose(P[b], probs[1 << np.arange(n)], atol=1e-10)
        assert abs(probs[1 << np.arange(n)].sum() - 1.0) < 1e-10  # stays in the unary subspace
        x_state = Statevector(loader)
        assert succ[b] == pytest.approx(lcu_success_probability(subs, alpha[b], x_state),
                                        abs=1e-10)


def test_one_subunitary_is_the_pure_model():
    circ = pyramid(4)
    lcu = LCUQNN([circ], FixedMixture([1.0]), seed=2)
    pure = DensityQNN([circ], FixedMixture([1.0]), encoding=Encoding.unary(4),
                      readout="unary_probabilities")
    pure.theta = lcu.theta.copy()
    X = RNG.normal(size=(5, 4))
    np.testing.assert_allclose(lcu.predict(X), pure.predict(X), atol=1e-12)
    np.testing.assert_allclose(lcu.success_probability(X), 1.0, atol=1e-12)


def test_from_density_shares_structure_and_copies_angles():
    dec = by_moments(round_robin(5))
    dens = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries),
                      encoding=Encoding.unary(5), readout="unary_probabilities", seed=1)
    lcu = LCUQNN.from_density(dens)
    np.testing.assert_array_equal(lcu.theta, dens.theta)
    lcu.theta = lcu.theta + 0.1
    assert not np.allclose(lcu.theta, dens.theta)
    with pytest.raises(TypeError, match="DensityQNN"):
        LCUQNN.from_density("model")


@pytest.mark.parametrize("wrt", ["all", "theta", "mixture"])
@pytest.mark.parametrize("mixture", ["softmax", "gated"])
def test_vjp_matches_finite_differences(mixture, wrt):
    n = 4
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    mix = SoftmaxMixture(logits=RNG.normal(size=K)) if mixture == "softmax" else \
        GatedMixture(n, K, seed=4)
    model = LCUQNN(dec.sub_unitaries, mix, seed=6)
    X = RNG.normal(size=(3, n))
    G = RNG.normal(size=(3, n))
    gt, gm = model.vjp(X, G, wrt=wrt)

    def loss():
        return float(np.sum(G * model.predict(X)))

    eps = 1e-6
    theta0 = model.theta.copy()
    fd = np.zeros_like(theta0)
    for i in range(theta0.size):
        for sign in (1, -1):
            t = theta0.copy()
            t[i] += sign * eps
            model.theta = t
            fd[i] += sign * loss() / (2 * eps)
    model.theta = theta0
    # the gradient not asked for is returned as zeros, the other one exact
    np.testing.assert_allclose(gt, 0.0 * fd if wrt == "mixture" else fd, atol=1e-7)
    p0 = model.mixture.params.copy()
    fdm = np.zeros_like(p0)
    for i in range(p0.size):
        for sign in (1, -1):
            p = p0.copy()
            p[i] += sign * eps
            model.mixture.params = p
            fdm[i] += sign * loss() / (2 * eps)
    model.mixture.params = p0
    np.testing.assert_allclose(gm, 0.0 * fdm if wrt == "theta" else fdm, atol=1e-7)
    assert gm.shape == fdm.shape


def test_shared_parameters_accumulate():
    circ = pyramid(3)
    model = LCUQNN([circ, circ], SoftmaxMixture(logits=[0.3, -0.2]), seed=1)
    assert model.theta.size == circ.num_parameters
    X = RNG.normal(size=(2, 3))
    G = RNG.normal(size=(2, 3))
    gt, _ = model.vjp(X, G)
    eps, theta0 = 1e-6, model.theta.copy()
    for i in range(theta0.size):
        t = theta0.copy()
        t[i] += eps
        model.theta = t
        up = np.sum(G * model.predict(X))
        t[i] -= 2 * eps
        model.theta = t
        down = np.sum(G * model.predict(X))
        assert gt[i] == pytest.approx((up - down) / (2 * eps), abs=1e-7)
    model.theta = theta0


def test_bad_input():
    from qiskit import QuantumCircuit

    with pytest.raises(ValueError, match="sub_unitaries"):
        LCUQNN([])
    hea = QuantumCircuit(2)
    hea.h(0)
    with pytest.raises(ValueError, match="Hamming-weight-preserving"):
        LCUQNN([hea])
    model = LCUQNN([pyramid(3)], seed=0)
    with pytest.raises(ValueError, match="grad_P"):
        model.vjp(np.ones((2, 3)), np.ones((2, 2)))
    with pytest.raises(ValueError, match="all-zero row"):
        model.predict(np.zeros((1, 3)))
