"""Fuzzing ``qdensity.models``: DensityQNN, Encoding, mixtures, decompositions.

Valid random angles and data: the unary engine's prediction equals Aer's exact statevector
(an independent path). Invalid input raises ``ValueError``/``TypeError`` naming the argument.
"""

from __future__ import annotations

import numpy as np
import pytest
from _fuzz import BAD_SIZES, HUGE, NON_FINITE, NOT_A_NUMBER, accepted, poison, refused
from hypothesis import given, settings
from hypothesis import strategies as st

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments, copies, cyclic_moments, odd_even
from qdensity.models.mixtures import FixedMixture, GatedMixture, SoftmaxMixture


def _model(n: int = 4, readout: str = "unary_probabilities") -> DensityQNN:
    return DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                      readout=readout, seed=0)


MODEL = _model()
P = MODEL.num_parameters
X = np.array([[1.0, 2.0, 3.0, 4.0]])


# ----------------------------------------------------------------------------- found cases
def test_found_predict_theta_wrong_length_and_nan():
    with pytest.raises(ValueError, match=r"theta must have shape \(6,\)"):
        MODEL.predict(X, theta=[0.1])
    with pytest.raises(ValueError, match="theta must be finite"):
        MODEL.predict(X, theta=np.full(P, np.nan))


def test_found_set_params_and_theta_attribute_refuse_nan():
    model = _model()
    before = model.theta.copy()
    with pytest.raises(ValueError, match="theta must be finite"):
        model.set_params(theta=np.full(P, np.nan))
    with pytest.raises(ValueError, match="theta must be finite"):
        model.theta = np.full(P, np.nan)
    with pytest.raises(ValueError, match=r"theta must have shape \(6,\)"):
        model.theta = np.zeros(P + 1)
    np.testing.assert_array_equal(model.theta, before)


def test_found_encoding_names_num_features_and_string_data():
    with pytest.raises(ValueError, match="num_features"):
        Encoding.unary(0)
    with pytest.raises(TypeError, match="X must be real numbers"):
        MODEL.predict([["a", "b", "c", "d"]])


def test_found_statevector_predict_refuses_40_qubits_before_allocating():
    wide = DensityQNN(by_moments(round_robin(40)).sub_unitaries[:2])
    with pytest.raises(ValueError, match=r"at most 24 qubits.*method='unary'"):
        wide.predict(None, method="statevector")


# ----------------------------------------------------------------------------- valid input
@settings(max_examples=6)
@given(seed=st.integers(0, 2**16), n=st.integers(3, 4))
def test_predict_unary_equals_statevector(seed, n):
    accepted("DensityQNN.predict")
    rng = np.random.default_rng(seed)
    model = _model(n)
    theta = rng.uniform(-np.pi, np.pi, model.num_parameters)
    x = rng.normal(size=(2, n))
    unary = model.predict(x, theta, method="unary")
    exact = model.predict(x, theta, method="statevector")
    np.testing.assert_allclose(unary, exact, atol=1e-9)
    np.testing.assert_allclose(unary.sum(axis=1), 1.0, atol=1e-9)


# ----------------------------------------------------------------------------- invalid input
@settings(max_examples=60)
@given(data=st.data())
def test_predict_bad_input_refused(data):
    kind = data.draw(st.sampled_from(["theta_nonfinite", "theta_shape", "theta_text", "X_nonfinite",
                                      "X_shape", "X_text", "X_empty", "X_zero", "method"]))
    X_, theta, method = X, None, "auto"
    if kind == "theta_nonfinite":
        theta = poison(np.zeros(P), data)
    elif kind == "theta_shape":
        shape = data.draw(st.sampled_from([(0,), (P - 1,), (P + 3,), (2, P + 1), (2, 2, P)]))
        theta = np.zeros(shape)
    elif kind == "theta_text":
        theta = data.draw(NOT_A_NUMBER.filter(lambda v: v is not None))
    elif kind == "X_nonfinite":
        X_ = poison(X, data)
    elif kind == "X_shape":
        X_ = np.ones(data.draw(st.sampled_from([(1, 3), (2, 5), (1, 1), (2, 2, 4)])))
    elif kind == "X_text":
        X_ = data.draw(NOT_A_NUMBER.filter(lambda v: v is not None))
    elif kind == "X_empty":
        X_ = np.zeros((0, 4))
    elif kind == "X_zero":
        X_ = np.zeros((1, 4))
    else:
        method = data.draw(st.text(max_size=6).filter(
            lambda s: s not in ("auto", "unary", "statevector")))
    refused("DensityQNN.predict", MODEL.predict, X_, theta, method=method)


@settings(max_examples=40)
@given(data=st.data())
def test_set_params_and_theta_refuse_bad_values(data):
    model = _model()
    bad = data.draw(st.one_of(
        st.builds(lambda: None).flatmap(lambda _: st.just(poison(np.zeros(P), data))),
        st.sampled_from([np.zeros(P - 1), np.zeros((2, P)), "abc", np.zeros(0)]),
    ))
    refused("DensityQNN.set_params", model.set_params, theta=bad)
    refused("DensityQNN.theta", setattr, model, "theta", bad)
    refused("DensityQNN.set_params", model.set_params,
            mixture=data.draw(st.one_of(NON_FINITE.map(lambda v: [v]), st.just([1.0]))))
    assert np.all(np.isfinite(model.theta))


@settings(max_examples=40)
@given(data=st.data())
def test_constructor_bad_input_refused(data):
    subs = by_moments(round_robin(4)).sub_unitaries
    kind = data.draw(st.sampled_from(["empty", "not_circuit", "widths", "mixture", "readout",
                                      "encoding", "observable"]))
    kwargs: dict = {"encoding": Encoding.unary(4), "readout": "unary_probabilities"}
    if kind == "empty":
        subs = []
    elif kind == "not_circuit":
        subs = [data.draw(NOT_A_NUMBER)]
    elif kind == "widths":
        subs = [round_robin(4), round_robin(3)]
    elif kind == "mixture":
        kwargs["mixture"] = data.draw(st.one_of(
            st.just([0.5, 0.6, 0.1]), st.just([1.0]), NON_FINITE.map(lambda v: [v, 0, 0]),
            st.just([-0.5, 1.0, 0.5]), st.text(max_size=3)))
    elif kind == "readout":
        kwargs["readout"] = data.draw(st.text(max_size=6))
    elif kind == "encoding":
        kwargs["encoding"] = Encoding.unary(3)
    else:
        kwargs = {"observable": data.draw(st.sampled_from(["ZZ", "Q", 3.5, "ZZZZZ"]))}
    refused("DensityQNN", DensityQNN, subs, **kwargs)


@settings(max_examples=30)
@given(n=st.one_of(BAD_SIZES, HUGE), d=BAD_SIZES)
def test_encodings_and_mixtures_bad_sizes_refused(n, d):
    refused("Encoding.unary", Encoding.unary, n)
    refused("Encoding.angle", Encoding.angle, n)
    refused("GatedMixture", GatedMixture, d, 2)
    refused("GatedMixture", GatedMixture, 2, d)
    refused("SoftmaxMixture", SoftmaxMixture, d)


@settings(max_examples=30)
@given(data=st.data())
def test_mixtures_bad_vectors_refused(data):
    bad = poison(np.array([0.5, 0.5]), data)
    refused("FixedMixture", FixedMixture, bad)
    refused("SoftmaxMixture", SoftmaxMixture, logits=bad)
    refused("FixedMixture", FixedMixture, data.draw(NOT_A_NUMBER))


@settings(max_examples=30)
@given(depth=st.one_of(BAD_SIZES, st.sampled_from([7, 100])), which=st.integers(0, 3))
def test_decompositions_bad_input_refused(depth, which):
    circ = pyramid(4)
    if which == 0:
        refused("by_moments", by_moments, circ, depth)
    elif which == 1:
        refused("cyclic_moments", cyclic_moments, circ, depth)
    elif which == 2:
        refused("copies", copies, circ, depth if depth not in (7, 100) else 0)
    else:
        refused("odd_even", odd_even, depth)
