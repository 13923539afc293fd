"""A model changed after use answers as a fresh one (nothing derived from its structure goes
stale): observable, mixture, sub-unitaries, encoding and readout set after a ``predict``.

Oracles: qiskit's ``Statevector`` (``sum_k alpha_k <psi_k| O |psi_k>`` for bound circuits),
central finite differences of those, and a model built fresh with the same settings.
"""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.gradients.density import density_gradient_plan
from qdensity.models.decompositions import by_moments, trainable_parameters
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.mixtures import FixedMixture

X = np.array([[0.3, -1.0, 0.7, 0.2], [1.0, 0.4, -0.2, 0.9]])


def _subs(seed_offset: int = 0):
    return by_moments(round_robin(4)).sub_unitaries


def _oracle(model, X, theta=None) -> np.ndarray:
    """``f(x) = sum_k alpha_k <V(x) U_k| O |...>`` from qiskit Statevectors."""
    theta = model.theta if theta is None else theta
    alpha = model.alpha(X)
    out = np.zeros(len(X))
    for b, x in enumerate(X):
        enc = model.encoding.circuit.assign_parameters(model.encoding.values(x[None])[0])
        for k, sub in enumerate(model.sub_unitaries):
            idx = [model.parameters.index(p) for p in trainable_parameters(sub)]
            bound = sub.assign_parameters(dict(zip(trainable_parameters(sub), theta[idx],
                                                   strict=True)))
            state = Statevector(enc.compose(bound))
            out[b] += alpha[b, k] * float(np.real(state.expectation_value(model.observable)))
    return out


def _model(**kw):
    kw.setdefault("encoding", Encoding.unary(4))
    return DensityQNN(_subs(), seed=3, **kw)


def test_observable_set_after_predict_answers_like_a_fresh_model():
    model = _model()
    model.predict(X)  # unary engine chosen and compiled for the Z readout
    model.observable = SparsePauliOp("IIXX")
    fresh = _model(observable=SparsePauliOp("IIXX"))
    got = np.ravel(model.predict(X))
    np.testing.assert_allclose(got, np.ravel(fresh.predict(X)), atol=1e-10)
    np.testing.assert_allclose(got, _oracle(model, X), atol=1e-10)


def test_observable_set_back_to_diagonal_uses_it():
    model = _model(observable=SparsePauliOp("IIXX"))
    model.predict(X)
    model.observable = SparsePauliOp("ZIII")
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_bad_observable_refused_on_set():
    model = _model()
    with pytest.raises((ValueError, TypeError), match="observable"):
        model.observable = SparsePauliOp("XX")  # 2 qubits on a 4-qubit model


def test_mixture_set_after_predict():
    model = _model()
    model.predict(X)
    K = model.num_subunitaries
    alpha = np.arange(1, K + 1, dtype=float) / np.arange(1, K + 1).sum()
    model.mixture = FixedMixture(alpha)
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_sub_unitaries_set_after_predict():
    model = _model()
    model.predict(X)
    new = [c.copy() for c in _subs()]
    for c in new:
        c.x(0)  # a different circuit with the same parameters
    model.sub_unitaries = new
    fresh = DensityQNN(new, encoding=Encoding.unary(4))
    fresh.theta = model.theta
    np.testing.assert_allclose(model.predict(X), fresh.predict(X), atol=1e-10)
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_gate_appended_in_place_is_seen():
    model = _model()
    model.predict(X)
    model.sub_unitaries[0].x(1)  # the fingerprint holds each circuit's instruction count
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_encoding_set_after_predict():
    model = _model()
    model.predict(X)
    model.encoding = Encoding.unary(4, layout="diagonal")
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_gradient_after_observable_change_matches_finite_differences():
    model = _model()
    density_gradient_plan(model, X[:1], method="commuting").run(ExactEngine())
    model.observable = SparsePauliOp("IZZI")
    grad = density_gradient_plan(model, X[:1], method="auto").run(ExactEngine())
    h = 1e-5
    for k, sub in enumerate(model.sub_unitaries):
        idx = [model.parameters.index(p) for p in trainable_parameters(sub)]
        for j, i in enumerate(idx):
            up, down = model.theta.copy(), model.theta.copy()
            up[i] += h
            down[i] -= h
            # f_k alone: alpha_k = 1 on sub-unitary k
            one = DensityQNN([sub], encoding=model.encoding, observable=model.observable)
            one.theta = up[idx]
            fp = _oracle(one, X[:1])
            one.theta = down[idx]
            fm = _oracle(one, X[:1])
            np.testing.assert_allclose(grad.jacobians[k][0, 0, j], (fp - fm)[0] / (2 * h),
                                       atol=1e-6)


def test_copied_model_derives_its_own():
    import copy

    model = _model()
    model.predict(X)
    twin = copy.deepcopy(model)
    twin.observable = SparsePauliOp("XXII")
    np.testing.assert_allclose(np.ravel(twin.predict(X)), _oracle(twin, X), atol=1e-10)
    np.testing.assert_allclose(np.ravel(model.predict(X)), _oracle(model, X), atol=1e-10)


def test_a_model_pickled_before_the_store_unpickles_and_stays_right():
    import pickle

    model = _model()
    model.predict(X)
    state = dict(model.__dict__)  # the attribute layout of earlier releases
    state["sub_unitaries"], state["observable"] = state.pop("_subs"), state.pop("_observable")
    state.pop("_derived")
    state["_unary_ok"], state["_num_uploaded"] = True, None
    old = DensityQNN.__new__(DensityQNN)
    old.__setstate__(state)
    back = pickle.loads(pickle.dumps(old))
    np.testing.assert_allclose(np.ravel(back.predict(X)), _oracle(back, X), atol=1e-10)
    back.observable = SparsePauliOp("IXXI")
    np.testing.assert_allclose(np.ravel(back.predict(X)), _oracle(back, X), atol=1e-10)
