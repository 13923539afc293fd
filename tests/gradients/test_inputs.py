"""Input gradients d f / d x (issue 26): the loader-angle Jacobian against central finite
differences of the loader angles, the quantum layer's d L / d x for every way data enter
a circuit (and through a data-dependent mixture) against central finite differences of Aer
statevector predictions, and sampled input gradients (shift rules on the data parameters, the
loader's RBS angles included) against exact ones within derived bounds, their shots on the
ledger."""

from __future__ import annotations

import numpy as np
import pytest
from _stats import FOUR_TERM_SQUARES, unary_input_vjp_sd
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector

from qdensity.circuits.ansatze import hardware_efficient, qcnn, round_robin
from qdensity.circuits.loaders import loader_angles
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.inputs import (
    encoding_jacobian,
    input_gradient_plan,
    loader_angles_jacobian,
)
from qdensity.learning.layer import QuantumLayer
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments, copies
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture

RNG = np.random.default_rng(2611)


@pytest.mark.parametrize("layout", ["parallel", "diagonal", "semi_diagonal"])
@pytest.mark.parametrize("d", [2, 3, 5, 8])
def test_loader_angles_jacobian_matches_finite_differences(layout, d):
    X = RNG.normal(size=(3, d))
    X[0, 0] = -2.0  # negative entries change the arctan2 branch
    jac = loader_angles_jacobian(X, layout)
    assert jac.shape == (3, d - 1, d)
    h = 1e-6
    for i in range(d):
        e = np.zeros(d)
        e[i] = h
        fd = (loader_angles(X + e, layout) - loader_angles(X - e, layout)) / (2 * h)
        np.testing.assert_allclose(jac[:, :, i], fd, atol=1e-7)


def test_encoding_jacobian_angle_identity_and_custom_encodings_need_one():
    X = RNG.normal(size=(2, 3))
    np.testing.assert_array_equal(encoding_jacobian(Encoding.angle(3), X),
                                  np.broadcast_to(np.eye(3), (2, 3, 3)))
    circ = Encoding.angle(3).circuit
    with pytest.raises(ValueError, match="kind 'other' need its jacobian"):
        encoding_jacobian(Encoding(circ, np.tanh, 3), X)
    given = Encoding(circ, np.tanh, 3, jacobian=lambda Z: np.einsum(
        "bi,ij->bij", 1 - np.tanh(Z) ** 2, np.eye(3)))
    np.testing.assert_allclose(np.einsum("bii->bi", encoding_jacobian(given, X)),
                               1 - np.tanh(X) ** 2)
    with pytest.raises(ValueError, match=r"must have shape \(2, 3, 3\)"):
        encoding_jacobian(Encoding(circ, np.tanh, 3, jacobian=lambda Z: Z), X)


def test_a_custom_encoding_with_its_jacobian_gives_input_gradients():
    """tanh before the angle encoding: d/dx against Aer finite differences."""
    circ = Encoding.angle(2).circuit
    enc = Encoding(circ, np.tanh, 2, jacobian=lambda Z: np.einsum(
        "bi,ij->bij", 1 - np.tanh(Z) ** 2, np.eye(2)))
    model = DensityQNN([hardware_efficient(2, 1)], None, encoding=enc, seed=7)
    _check_against_aer(model)


def _reuploading(x=None):
    x, t = x if x is not None else ParameterVector("x", 2), ParameterVector("t", 4)
    qc = QuantumCircuit(2)
    qc.rx(x[0], 0)
    qc.ry(t[0], 0)
    qc.rx(2 * x[1] - 0.3, 1)  # a data angle with a coefficient and an offset
    qc.cz(0, 1)
    qc.rx(x[0], 1)
    qc.ry(t[1], 1)
    qc.rz(t[2], 0)
    qc.cx(1, 0)
    qc.ry(t[3], 0)
    return qc


def _models():
    yield "angle+hea", DensityQNN(copies(hardware_efficient(3, 2, ("ry", "rz")), 2).sub_unitaries,
                                  SoftmaxMixture(2), encoding=Encoding.angle(3), seed=1)
    yield "unary+hea", DensityQNN(copies(hardware_efficient(3, 1), 2).sub_unitaries,
                                  SoftmaxMixture(2), encoding=Encoding.unary(3), seed=2)
    yield "reuploading", DensityQNN([_reuploading()], None, seed=3)
    enc = Encoding.angle(2)  # the encoding's own parameters re-uploaded later in the circuit
    yield "angle+reuploading", DensityQNN([_reuploading(enc.circuit.parameters)], None,
                                          encoding=enc, seed=4)
    yield "angle+qcnn", DensityQNN([qcnn(4)], None, encoding=Encoding.angle(4), seed=5)
    # data-dependent mixtures: d alpha / dx times the outputs joins alpha d f_k / dx
    yield "angle+hea+moe*", DensityQNN(copies(hardware_efficient(3, 1), 2).sub_unitaries,
                                       GatedMixture(3, 2, activation="gelu", seed=6),
                                       encoding=Encoding.angle(3), seed=6)
    dec = by_moments(round_robin(4))  # the unary engine's reverse mode
    yield "unary+rbs+moe", DensityQNN(dec.sub_unitaries, GatedMixture(4, dec.num_subunitaries,
                                                                      seed=7),
                                      encoding=Encoding.unary(4), readout="unary_probabilities",
                                      seed=7)


@pytest.mark.parametrize(("name", "model"), list(_models()), ids=[n for n, _ in _models()])
def test_quantum_layer_input_gradient_matches_aer_finite_differences(name, model):
    _check_against_aer(model)


def _check_against_aer(model):
    layer = QuantumLayer(model, "exact")
    d = model.encoding.num_features if model.encoding is not None else model.num_qubits
    X = RNG.normal(size=(2, d)) + 0.3
    F = layer.forward(X)
    w = RNG.normal(size=F.shape)
    gx = layer.backward(w)
    assert gx is not None and gx.shape == X.shape

    def loss(Z):
        out = model.predict(Z, method="statevector")
        return float((out.reshape(F.shape) * w).sum())

    h = 1e-5
    fd = np.zeros_like(X)
    for b in range(X.shape[0]):
        for i in range(d):
            e = np.zeros_like(X)
            e[b, i] = h
            fd[b, i] = (loss(X + e) - loss(X - e)) / (2 * h)
    np.testing.assert_allclose(gx, fd, atol=1e-7)


def test_input_gradient_plan_exact_and_sampled():
    """Shift rules on the data parameters: exact on Aer equal to the adjoint input gradient;
    sampled within 4 standard errors; circuits per point in the plan's meta."""
    from qdensity.gradients.inputs import input_jacobians
    from qdensity.models.exact import exact_gradients

    enc = Encoding.angle(2)
    model = DensityQNN([_reuploading(enc.circuit.parameters), hardware_efficient(2, 1)],
                       SoftmaxMixture(2), encoding=enc, seed=9)
    X = RNG.normal(size=(3, 2))
    plan = input_gradient_plan(model, X)
    # k = 0: x[0] in 3 rx gates, x[1] in 2 (encoding + re-upload), 2 terms each;
    # k = 1: the encoding's 2 rx gates; one measurement group (Z) per circuit
    assert plan.meta["input_circuits"] == 2 * (5 + 2)
    assert plan.num_circuits == 3 * plan.meta["input_circuits"]
    exact = plan.run(ExactEngine())
    ref = input_jacobians(model, X, exact_gradients(model, X))
    for est, r in zip(exact, ref, strict=True):
        np.testing.assert_allclose(est.value, r, atol=1e-10)
    sampled = input_gradient_plan(model, X, shots=4000).run(SamplerEngine(seed=_stat_seed(3)))
    # 2 sub-unitaries x 3 rows x 2 inputs, each normal (4000 shots) within 4 of its standard
    # errors: false failure <= 12 x 2 Phi(-4) = 8e-4
    for est, r in zip(sampled, ref, strict=True):
        assert np.all(np.abs(est.value - r) <= 4 * est.standard_error + 1e-12)
        assert np.all(est.standard_error > 0)
    with pytest.raises(ValueError, match="'unary_amplitudes' .*signs are not measured"):
        input_gradient_plan(DensityQNN([round_robin(3)], None,
                                       encoding=Encoding.unary(3),
                                       readout="unary_amplitudes"), RNG.normal(size=(1, 3)))


@pytest.mark.parametrize("activation", [None, "gelu"])
def test_gated_mixture_input_vjp_matches_finite_differences(activation):
    """d alpha / dx of the mixture-of-experts gate (eq. 26), against central differences."""
    gate = GatedMixture(3, 4, activation=activation, bias=RNG.normal(size=4), seed=8)
    X = RNG.normal(size=(2, 3))
    g = RNG.normal(size=(2, 4))
    h = 1e-6
    fd = np.zeros_like(X)
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        fd[:, i] = ((gate.alpha(X + e) - gate.alpha(X - e)) * g).sum(axis=1) / (2 * h)
    np.testing.assert_allclose(gate.input_vjp(X, g), fd, atol=1e-8)
    np.testing.assert_array_equal(SoftmaxMixture(4).input_vjp(X, g), np.zeros_like(X))
    with pytest.raises(ValueError, match=r"grad_alpha must have shape \(2, 4\)"):
        gate.input_vjp(X, g[:, :3])


def _unary_rbs(mixture, n=4, seed=0):
    dec = by_moments(round_robin(n))
    mix = (SoftmaxMixture(dec.num_subunitaries) if mixture == "softmax"
           else GatedMixture(n, dec.num_subunitaries, seed=seed + 1))
    return DensityQNN(dec.sub_unitaries, mix, encoding=Encoding.unary(n),
                      readout="unary_probabilities", seed=seed)


def test_input_gradient_plan_on_unary_probabilities_exact_and_sampled():
    """The four-term rule on the loader's RBS angles chained with d phi / dx: exact on Aer
    equal to central differences of the exact model's outputs f_k; sampled within derived
    bounds, its shots on the ledger equal to what the plan's meta states."""
    n, shots = 4, 10_000
    model = _unary_rbs("softmax", n, seed=11)
    K = model.num_subunitaries
    X = RNG.uniform(0.2, 1.0, (2, n))
    X[0, 1] = -0.6  # a negative entry
    plan = input_gradient_plan(model, X)
    # independent count: four terms per loader RBS (n - 1 of them), one circuit reads every
    # unary probability, for each sub-unitary
    assert plan.meta["input_circuits_per_subunitary"] == [4 * (n - 1)] * K
    assert plan.meta["input_circuits"] == 4 * (n - 1) * K
    assert plan.num_circuits == X.shape[0] * plan.meta["input_circuits"]
    h = 1e-6
    fd = np.zeros((X.shape[0], K, n, n))  # (B, K, outputs, features)
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        fd[..., i] = (model.expert_outputs(X + e, method="statevector")
                      - model.expert_outputs(X - e, method="statevector")) / (2 * h)
    for k, est in enumerate(plan.run(ExactEngine())):
        np.testing.assert_allclose(est.value, fd[:, k], atol=1e-7)
    engine = SamplerEngine(seed=_stat_seed(7))
    splan = input_gradient_plan(model, X, shots=shots)
    sampled = splan.run(engine)
    assert engine.ledger.total_shots == X.shape[0] * splan.meta["input_circuits"] * shots
    # d p_j / dx_i = sum_c J_ci sum_t c_t p_j(shift t of angle c): independent rows, each
    # frequency of variance <= 1 / (4 shots), so Var <= sum_c J_ci^2 FOUR_TERM_SQUARES / (4 shots)
    J = loader_angles_jacobian(X)
    sd = np.sqrt((J**2).sum(axis=1) * FOUR_TERM_SQUARES / (4 * shots))  # (B, d)
    # K x B x n x d = 96 entries, each normal with sd below this bound, within 5 of it:
    # false failure <= 96 x 2 Phi(-5) = 5.5e-5
    for k, est in enumerate(sampled):
        assert est.value.shape == (X.shape[0], n, n)
        assert np.all(np.abs(est.value - fd[:, k]) <= 5 * sd[:, None, :])
        assert np.all(est.standard_error > 0)


def _gate_jacobian(gate, X):
    """d alpha_k / dx of softmax(W x + b), written out: alpha_k (W_k - sum_l alpha_l W_l)."""
    a = gate.alpha(X)
    mean_w = a @ gate.weights
    return a[:, :, None] * (gate.weights[None, :, :] - mean_w[:, None, :])


def test_sampled_input_gradient_through_a_gated_mixture():
    """A QuantumLayer on a SamplerEngine with input_gradients: dL/dx of a unary-probability
    model with a data-dependent mixture (alpha d f_k / dx from the loader's shift circuits plus
    d alpha / dx times the sampled forward outputs) within a derived bound of the exact one;
    the input-gradient circuits' shots on the ledger as the plan's meta states."""
    n, shots = 4, 10_000
    model = _unary_rbs("moe", n, seed=12)
    X = RNG.uniform(0.2, 1.0, (2, n))
    exact = QuantumLayer(model, "exact")
    F = exact.forward(X)
    w = RNG.normal(size=F.shape)
    gx = exact.backward(w)
    engine = SamplerEngine(seed=_stat_seed(13))
    layer = QuantumLayer(model, engine, shots=shots, input_gradients=True)
    layer.forward(X)
    gs = layer.backward(w)
    assert layer.shots_spent == engine.ledger.total_shots
    meta = input_gradient_plan(model, X).meta
    spent = sum(s for label, (_, s) in engine.ledger.by_label().items()
                if label.startswith("input_gradient"))
    assert spent == X.shape[0] * meta["input_circuits"] * shots
    sd = unary_input_vjp_sd(model.alpha(X), loader_angles_jacobian(X), w, shots,
                            _gate_jacobian(model.mixture, X))
    # B x d = 8 entries, each normal with sd below the bound, within 5 of it:
    # false failure <= 8 x 2 Phi(-5) = 4.6e-6
    assert np.all(np.abs(gs - gx) <= 5 * sd)
    plain = QuantumLayer(model, ExactEngine())  # no input-gradient circuits asked for
    plain.forward(X)
    assert plain.backward(w) is None
    with pytest.raises(TypeError, match="input_gradients must be a bool"):
        QuantumLayer(model, engine, shots=shots, input_gradients="yes")
