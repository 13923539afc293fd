"""Input gradients d f / d x (issue 26): the loader-angle Jacobian against central finite
differences of the loader angles, and the quantum layer's d L / d x for every way data enter
a circuit against central finite differences of Aer statevector predictions."""

from __future__ import annotations

import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector

from qdensity.circuits.ansatze import hardware_efficient, qcnn, round_robin
from qdensity.circuits.loaders import loader_angles
from qdensity.gradients.inputs import encoding_jacobian, loader_angles_jacobian
from qdensity.learning.layer import QuantumLayer
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import copies
from qdensity.models.mixtures import SoftmaxMixture

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
    from qdensity.execution.engines import ExactEngine, SamplerEngine
    from qdensity.gradients.inputs import input_gradient_plan, input_jacobians
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
    seed = _stat_seed(3)  # benchmarks/fuzz_statistics.py
    sampled = input_gradient_plan(model, X, shots=4000).run(SamplerEngine(seed=seed))
    # 2 sub-unitaries x 3 rows x 2 inputs, each normal (4000 shots) within 4 of its standard
    # errors: false failure <= 12 x 2 Phi(-4) = 8e-4
    for est, r in zip(sampled, ref, strict=True):
        assert np.all(np.abs(est.value - r) <= 4 * est.standard_error + 1e-12)
        assert np.all(est.standard_error > 0)
    with pytest.raises(ValueError, match="readout='observable'"):
        input_gradient_plan(DensityQNN([round_robin(3)], None,
                                       encoding=Encoding.unary(3),
                                       readout="unary_probabilities"), RNG.normal(size=(1, 3)))
