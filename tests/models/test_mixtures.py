"""Oracle tests for mixtures (``qdensity.models.mixtures``; paper eq. 1, eq. 2, Supp. H eq. 26).

Oracles: the softmax written out with ``math.exp``, GELU with ``math.erf``, and central finite
differences of the scalar ``sum(grad_alpha * alpha(X))`` with respect to the flat parameters
(the vector-Jacobian product's definition).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from qdensity.models.mixtures import (
    FixedMixture,
    GatedMixture,
    SoftmaxMixture,
    as_mixture,
    softmax,
)

H = 1e-6


def naive_softmax(z) -> np.ndarray:
    e = [math.exp(v) for v in z]
    return np.array(e) / sum(e)


def fd_vjp(mixture, X, grad_alpha) -> np.ndarray:
    """Central finite differences of ``sum(grad_alpha * alpha(X))`` in ``mixture.params``."""
    base = mixture.params.copy()
    out = np.zeros(base.size)
    for k in range(base.size):
        e = np.zeros(base.size)
        e[k] = H
        mixture.params = base + e
        plus = float(np.sum(grad_alpha * mixture.alpha(X)))
        mixture.params = base - e
        minus = float(np.sum(grad_alpha * mixture.alpha(X)))
        out[k] = (plus - minus) / (2 * H)
    mixture.params = base
    return out


# --------------------------------------------------------------------------------- softmax


@settings(max_examples=20, deadline=None)
@given(z=st.lists(st.floats(-20, 20), min_size=1, max_size=6))
def test_softmax_matches_naive_formula(z):
    np.testing.assert_allclose(softmax(np.array(z)), naive_softmax(z), rtol=1e-12, atol=1e-300)


def test_softmax_rows_shift_invariance_and_large_logits():
    z = np.array([[1.0, 2.0, 3.0], [1000.0, 1000.0, -1000.0]])
    out = softmax(z)
    np.testing.assert_allclose(out[0], naive_softmax(z[0]), rtol=1e-12)
    np.testing.assert_allclose(out[1], [0.5, 0.5, 0.0], atol=1e-300)
    np.testing.assert_allclose(softmax(z[0] + 123.4), out[0], rtol=1e-12)
    assert np.all(np.isfinite(out))


# --------------------------------------------------------------------------------- softmax mix


@settings(max_examples=15, deadline=None)
@given(k=st.integers(1, 5), batch=st.integers(1, 3), seed=st.integers(0, 10_000))
def test_softmax_mixture_vjp_equals_finite_differences(k, batch, seed):
    rng = np.random.default_rng(seed)
    mix = SoftmaxMixture(logits=rng.normal(size=k))
    X = rng.normal(size=(batch, 2))
    g = rng.normal(size=(batch, k))
    alpha = mix.alpha(X)
    assert alpha.shape == (batch, k)
    np.testing.assert_allclose(alpha[0], naive_softmax(mix.logits), rtol=1e-12)
    np.testing.assert_allclose(mix.vjp(X, g), fd_vjp(mix, X, g), atol=1e-8)


def test_softmax_mixture_constructors():
    np.testing.assert_allclose(SoftmaxMixture(4).alpha()[0], [0.25] * 4)
    target = np.array([0.1, 0.6, 0.3])
    np.testing.assert_allclose(SoftmaxMixture(alpha=target).alpha()[0], target, rtol=1e-12)
    with pytest.raises(ValueError, match="exactly one"):
        SoftmaxMixture(3, logits=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="exactly one"):
        SoftmaxMixture()
    with pytest.raises(ValueError, match="strictly positive"):
        SoftmaxMixture(alpha=[0.5, 0.5, 0.0])
    mix = SoftmaxMixture(3)
    with pytest.raises(ValueError, match="length 3"):
        mix.params = [0.0, 1.0]
    with pytest.raises(ValueError, match="finite"):
        SoftmaxMixture(logits=[0.0, np.inf])


# ----------------------------------------------------------------------------------- gated


@pytest.mark.parametrize("activation", [None, "gelu"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gated_mixture_vjp_equals_finite_differences(activation, seed):
    rng = np.random.default_rng(seed)
    d, k, batch = 3, 4, 5
    mix = GatedMixture(d, k, activation=activation, bias=rng.normal(size=k), seed=seed)
    X = rng.normal(size=(batch, d))
    g = rng.normal(size=(batch, k))
    assert mix.params.size == k * d + k
    np.testing.assert_allclose(mix.vjp(X, g), fd_vjp(mix, X, g), atol=1e-7)


@pytest.mark.parametrize("activation", [None, "gelu"])
def test_gated_mixture_alpha_formula(activation):
    rng = np.random.default_rng(9)
    W, b = rng.normal(size=(3, 2)), rng.normal(size=3)
    mix = GatedMixture(2, 3, activation=activation, weights=W, bias=b)
    X = rng.normal(size=(4, 2))
    for x, row in zip(X, mix.alpha(X), strict=True):
        z = W @ x + b
        if activation == "gelu":
            z = np.array([v * 0.5 * (1 + math.erf(v / math.sqrt(2))) for v in z])
        np.testing.assert_allclose(row, naive_softmax(z), rtol=1e-12)
    # one sample as a vector
    np.testing.assert_allclose(mix.alpha(X[0]), mix.alpha(X[:1]), rtol=0)


def test_gated_mixture_errors():
    with pytest.raises(ValueError, match=r"\(3, 2\)"):
        GatedMixture(2, 3, weights=np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"bias must have shape \(3,\)"):
        GatedMixture(2, 3, bias=np.zeros(2))
    with pytest.raises(ValueError, match="activation"):
        GatedMixture(2, 3, activation="relu")
    mix = GatedMixture(2, 3, seed=0)
    with pytest.raises(ValueError, match="2 features"):
        mix.alpha(np.zeros((1, 3)))
    with pytest.raises(ValueError, match="needs the data X"):
        mix.alpha()
    with pytest.raises(ValueError, match="length 9"):
        mix.params = np.zeros(8)
    with pytest.raises(ValueError, match="num_features"):
        GatedMixture(0, 3)


def test_gated_mixture_seeded_initialisation_repeats():
    a, b = GatedMixture(3, 2, seed=5), GatedMixture(3, 2, seed=5)
    np.testing.assert_array_equal(a.params, b.params)
    np.testing.assert_array_equal(a.bias, 0.0)


# ----------------------------------------------------------------------------------- fixed


def test_fixed_mixture_refuses_off_simplex_alpha():
    with pytest.raises(ValueError, match="non-negative"):
        FixedMixture([1.2, -0.2])
    with pytest.raises(ValueError, match="finite"):
        FixedMixture([np.nan, 1.0])
    for total in (1 + 1e-6, 1 - 1e-6):
        with pytest.raises(ValueError, match="not renormalised"):
            FixedMixture([0.5, total - 0.5])
    with pytest.raises(ValueError, match="alpha"):
        FixedMixture([])


def test_fixed_mixture_accepts_sum_within_tolerance():
    alpha = [0.25, 0.75 + 1e-12]
    mix = FixedMixture(alpha)
    np.testing.assert_array_equal(mix.alpha()[0], alpha)  # never renormalised
    assert mix.alpha(np.zeros((3, 5))).shape == (3, 2)
    assert mix.num_params == 0
    assert mix.vjp(None, np.ones((1, 2))).size == 0
    with pytest.raises(ValueError, match="no trainable parameters"):
        mix.params = [0.1]


def test_as_mixture():
    np.testing.assert_allclose(as_mixture(None, 4).alpha()[0], [0.25] * 4)
    assert isinstance(as_mixture([0.2, 0.8], 2), FixedMixture)
    mix = SoftmaxMixture(3)
    assert as_mixture(mix, 3) is mix
    with pytest.raises(ValueError, match="3 components but there are 2"):
        as_mixture(mix, 2)
