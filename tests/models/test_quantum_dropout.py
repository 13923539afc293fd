"""Quantum dropout (randomised training, deterministic inference) against independent oracles:
Qiskit statevectors and the partial trace of the deterministic circuit (Fig. 1b) for the
prediction, central finite differences for the mean of the randomised gradient."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.quantum_info import DensityMatrix, SparsePauliOp, Statevector, partial_trace

from qdensity.execution import ShotLedger
from qdensity.models.dropout import QuantumDropout
from qdensity.models.single_qubit import SingleQubitReuploading


def _sub_circuit(theta_k, x, encoding):
    """One sub-unitary gate by gate: per layer the data rotations, then R_z R_y R_z."""
    qc = QuantumCircuit(1)
    for t1, t2, t3 in theta_k:
        qc.rx(x, 0)
        if encoding == "rx_ry":
            qc.ry(x, 0)
        qc.rz(t3, 0)
        qc.ry(t2, 0)
        qc.rz(t1, 0)
    return qc


def _model(K=2, L=2, encoding="rx_ry", seed=3):
    model = SingleQubitReuploading(L, K, encoding=encoding, seed=seed)
    model.logits = np.array([0.4, -0.3, 0.1][:K])
    return model


@pytest.mark.parametrize("encoding", ["rx", "rx_ry"])
def test_deterministic_prediction_is_the_mixture(encoding):
    """eval().predict equals sum_k alpha_k <Z>_k from Qiskit statevectors and <Z> of the data
    qubit after tracing out the ancilla of the deterministic circuit (sqrt(alpha) load, then
    U_0 controlled on |0>, U_1 on |1>)."""
    model = _model(encoding=encoding)
    drop = QuantumDropout(model, shots=10).eval()
    X = np.array([-0.7, 0.1, 0.9])
    alpha = model.alpha
    z = SparsePauliOp("Z")
    for x, got in zip(X, drop.predict(X), strict=True):
        subs = [_sub_circuit(model.theta[k], x, encoding) for k in range(2)]
        mix = sum(a * Statevector(c).expectation_value(z).real
                  for a, c in zip(alpha, subs, strict=True))
        det = QuantumCircuit(2)  # qubit 0: data, qubit 1: ancilla
        det.ry(2 * np.arccos(np.sqrt(alpha[0])), 1)
        det.append(subs[0].to_gate().control(1, ctrl_state=0), [1, 0])
        det.append(subs[1].to_gate().control(1, ctrl_state=1), [1, 0])
        rho = partial_trace(DensityMatrix(det), [1])
        assert got == pytest.approx(mix, abs=1e-10)
        assert got == pytest.approx(rho.expectation_value(z).real, abs=1e-10)


def _finite_difference(model, X, y, h=1e-6):
    p0 = model.get_params()
    grad = np.zeros_like(p0)
    for i in range(p0.size):
        for sgn in (1, -1):
            p = p0.copy()
            p[i] += sgn * h
            model.set_params(p)
            grad[i] += sgn * model.mse(X, y) / (2 * h)
    model.set_params(p0)
    return grad


def test_randomised_gradient_is_unbiased():
    """The mean of 600 seeds' train-mode gradients lies within 5 standard errors of the
    finite-difference gradient in every one of its 14 components (a false failure about
    14 x 6e-7)."""
    model = _model()
    X, y = np.array([-0.5, 0.2, 0.8]), np.array([0.3, -0.1, 0.4])
    exact = _finite_difference(model, X, y)
    drop = QuantumDropout(model, shots=20).train()
    grads = np.array([drop.loss_and_grad(X, y, seed=s)[1] for s in range(600)])
    mean, se = grads.mean(axis=0), grads.std(axis=0, ddof=1) / np.sqrt(len(grads))
    assert np.all(se > 0)
    assert np.all(np.abs(mean - exact) < 5 * se), np.abs(mean - exact) / se
    assert np.allclose(drop.eval().loss_and_grad(X, y)[1], exact, atol=1e-6)


def test_shots_and_ledger():
    model = _model(K=3, L=2)
    drop = QuantumDropout(model, shots=50)
    ledger = ShotLedger()
    X, y = np.array([0.1, 0.2]), np.array([0.0, 0.5])
    a = drop.loss_and_grad(X, y, seed=7, ledger=ledger)
    b = drop.loss_and_grad(X, y, seed=7)
    assert a[0] == b[0] and np.array_equal(a[1], b[1])
    shots = ledger.by_label()
    assert sum(shots[f"forward_k{k}"][1] for k in range(3)) == 2 * 50
    assert sum(shots[f"mixture_k{k}"][1] for k in range(3)) == 2 * 50
    assert sum(shots[f"shift_k{k}"][1] for k in range(3)) == 2 * 3 * 2 * 2 * 50


def test_sampled_prediction_within_its_binomial_bound():
    model = _model()
    drop = QuantumDropout(model)
    X = np.array([0.3])
    f = drop.predict(X)[0]
    est = drop.predict(X, shots=40_000, seed=2)[0]
    assert abs(est - f) < 5 * np.sqrt((1 - f**2) / 40_000)  # false failure ~6e-7


def test_bad_input():
    with pytest.raises(TypeError, match="model"):
        QuantumDropout("model")
    with pytest.raises(ValueError, match="shots"):
        QuantumDropout(_model(), shots=0)
    with pytest.raises(ValueError, match="y must have shape"):
        QuantumDropout(_model()).loss_and_grad([0.1, 0.2], [0.1])
    with pytest.raises(TypeError, match="ledger"):
        QuantumDropout(_model()).loss_and_grad([0.1], [0.1], ledger=[])
