"""The linear read-out, losses, optimisers and parameter files (qdensity.learning.nn / losses /
optim).

Oracles: central finite differences (float64, h = 1e-6) for every backward pass and every
loss gradient; scipy's softmax / log-softmax / normal CDF for values; the textbook update
formulas of SGD-momentum, RMSprop and Adam evaluated by hand with scalar arithmetic; exact
round trips for files.
"""

from __future__ import annotations

import math
import pickle
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from qdensity.learning.losses import (
    accuracy,
    cross_entropy_with_logits,
    l2_penalty,
    mse,
)
from qdensity.learning.nn import (
    Linear,
    get_flat,
    load_parameters,
    save_parameters,
    set_flat,
)
from qdensity.learning.optim import SGD, Adam, RMSprop

H = 1e-6
FAST = settings(max_examples=15, deadline=None)


# ---------------------------------------------------------------------------------------------
# finite-difference oracles


def fd_grad(f, x: np.ndarray, h: float = H) -> np.ndarray:
    """Central differences of a scalar function ``f`` at ``x`` (x is perturbed in place)."""
    g = np.zeros_like(x)
    it = np.nditer(x, flags=["multi_index"])
    for _ in it:
        i = it.multi_index
        old = x[i]
        x[i] = old + h
        fp = f()
        x[i] = old - h
        fm = f()
        x[i] = old
        g[i] = (fp - fm) / (2 * h)
    return g


def check_layer(layer, X: np.ndarray, seed: int = 0) -> None:
    """Backward of ``layer`` (input and every parameter) vs central differences of
    ``L = sum(R * layer(X))`` for a random cotangent ``R``."""
    rng = np.random.default_rng(seed)
    Y = layer.forward(X)
    R = rng.normal(size=Y.shape)
    gX = layer.backward(R)
    grads = {k: v.copy() for k, v in layer.grads.items()}
    assert set(grads) == set(layer.params)
    X = X.copy()

    def loss():
        return float(np.sum(R * layer.forward(X)))

    np.testing.assert_allclose(gX, fd_grad(loss, X), rtol=1e-5, atol=1e-7)
    for key, arr in layer.params.items():
        assert grads[key].shape == arr.shape
        np.testing.assert_allclose(grads[key], fd_grad(loss, arr), rtol=1e-5, atol=1e-7)


# ---------------------------------------------------------------------------------------------
# layers: gradients


shapes = st.tuples(st.integers(1, 4), st.integers(1, 5), st.integers(1, 5), st.integers(0, 10**6))


@FAST
@given(shapes, st.booleans())
def test_linear_backward_matches_finite_differences(shape, bias):
    B, din, dout, seed = shape
    layer = Linear(din, dout, seed=seed, bias=bias)
    if bias:  # a non-zero bias so that the forward pass really uses it
        layer.params["b"][...] = np.random.default_rng(seed + 1).normal(size=dout)
    assert set(layer.params) == ({"W", "b"} if bias else {"W"})
    check_layer(layer, np.random.default_rng(seed).normal(size=(B, din)), seed)


def test_linear_forward_is_affine_map():
    layer = Linear(3, 2, seed=1)
    layer.params["b"][...] = [0.5, -1.0]
    X = np.array([[1.0, 2.0, 3.0]])
    W = layer.params["W"]
    expected = [sum(X[0, i] * W[i, j] for i in range(3)) + layer.params["b"][j] for j in range(2)]
    np.testing.assert_allclose(layer.forward(X)[0], expected, rtol=1e-14)










# ---------------------------------------------------------------------------------------------
# layers: values












# ---------------------------------------------------------------------------------------------
# layers: errors and flat vectors


def test_layer_errors():
    lin = Linear(3, 2, seed=0)
    with pytest.raises(RuntimeError, match="before forward"):
        lin.backward(np.ones((1, 2)))
    with pytest.raises(ValueError, match=r"shape \(batch, 3\).*\(2, 4\)"):
        lin.forward(np.ones((2, 4)))
    with pytest.raises(ValueError, match="2-dimensional"):
        lin.forward(np.ones(3))
    with pytest.raises(ValueError, match="finite"):
        lin.forward(np.array([[1.0, np.nan, 0.0]]))
    lin.forward(np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"grad_Y must have the shape.*\(2, 2\).*\(2, 3\)"):
        lin.backward(np.ones((2, 3)))
    with pytest.raises(ValueError, match="in_features must be >= 1"):
        Linear(0, 2)
    with pytest.raises(TypeError, match="out_features must be an int"):
        Linear(2, 2.5)
    with pytest.raises(TypeError, match="bias must be a bool"):
        Linear(2, 2, bias="yes")
    with pytest.raises(TypeError, match="seed"):
        Linear(2, 2, seed="abc")


def test_seeds_give_identical_glorot_inits():
    a, b = Linear(4, 3, seed=5), Linear(4, 3, seed=5)
    np.testing.assert_array_equal(a.params["W"], b.params["W"])
    c = Linear(4, 3, seed=np.random.default_rng(5))
    np.testing.assert_array_equal(a.params["W"], c.params["W"])
    assert not np.array_equal(a.params["W"], Linear(4, 3, seed=6).params["W"])
    np.testing.assert_array_equal(a.params["b"], 0.0)
    # Glorot-uniform: |W| <= sqrt(6 / (in + out)), variance limit^2 / 3 within 5 std errors
    big = Linear(150, 250, seed=1).params["W"]
    limit = math.sqrt(6 / 400)
    assert np.all(np.abs(big) <= limit)
    n = big.size
    var_u = limit**2 / 3
    se = math.sqrt((limit**4 / 5 - var_u**2) / n)  # std of the mean of W^2
    assert abs(np.mean(big**2) - var_u) < 5 * se


def test_get_and_set_flat():
    lin = Linear(3, 2, seed=0)
    flat = get_flat(lin)
    np.testing.assert_array_equal(flat, np.concatenate([lin.params["W"].ravel(),
                                                        lin.params["b"]]))
    assert flat.shape == (lin.num_parameters,) == (8,)
    set_flat(lin, np.arange(8.0))
    np.testing.assert_array_equal(lin.params["W"], np.arange(6.0).reshape(3, 2))
    np.testing.assert_array_equal(lin.params["b"], [6.0, 7.0])
    X = np.ones((1, 3))
    np.testing.assert_allclose(lin.forward(X), X @ np.arange(6.0).reshape(3, 2) + [6, 7])
    lin.backward(np.ones((1, 2)))
    np.testing.assert_array_equal(get_flat(lin.grads)[6:], [1.0, 1.0])
    lin.zero_grad()
    np.testing.assert_array_equal(get_flat(lin.grads), 0.0)
    with pytest.raises(ValueError, match=r"flat must have shape \(8,\).*\(7,\)"):
        set_flat(lin, np.zeros(7))
    with pytest.raises(ValueError, match="finite"):
        set_flat(lin, np.full(8, np.inf))
    with pytest.raises(TypeError, match="target must be a layer"):
        get_flat(3.0)
    assert get_flat({}).shape == (0,)


# ---------------------------------------------------------------------------------------------
# losses


def _fd_loss(fn, x, *args, **kw):
    x = np.array(x, dtype=float)
    return fd_grad(lambda: fn(x, *args, **kw)[0], x)


def test_mse_value_and_gradient():
    rng = np.random.default_rng(1)
    p, t = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    loss, g = mse(p, t)
    assert loss == pytest.approx(np.sum((p - t) ** 2) / 12, rel=1e-14)
    np.testing.assert_allclose(g, _fd_loss(mse, p, t), rtol=1e-6, atol=1e-9)








def test_cross_entropy_with_logits_is_stable():
    Z = np.array([[1000.0, 0.0, -1000.0], [1e6, 1e6, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loss, g = cross_entropy_with_logits(Z, [1, 0])
    assert loss == pytest.approx((1000.0 + math.log(2)) / 2, rel=1e-14)
    assert np.all(np.isfinite(g))
    np.testing.assert_allclose(g.sum(axis=1), 0.0, atol=1e-15)


def test_l2_penalty():
    w = np.array([1.0, -2.0, 0.5])
    loss, g = l2_penalty(w, 0.1)
    assert loss == pytest.approx(0.1 * 5.25)
    np.testing.assert_allclose(g, _fd_loss(l2_penalty, w, 0.1), rtol=1e-6)
    with pytest.raises(ValueError, match="strength must be finite and >= 0"):
        l2_penalty(w, -1.0)


def test_l2_penalty_keeps_zero_parameters_at_a_zero_gradient_at_any_finite_strength():
    # the gradient 2 s w is exactly 0 where w is 0, whatever the strength: with s at the
    # largest float, 2 s overflows, and (2 s) * 0 would be NaN
    big = float(np.finfo(float).max)
    loss, g = l2_penalty(np.array([0.0, 0.0]), big)
    assert loss == 0.0
    assert np.array_equal(g, [0.0, 0.0])
    _, g = l2_penalty(np.array([0.0, 1e-300]), big)
    assert g[0] == 0.0 and np.isfinite(g[1]) and g[1] == pytest.approx(big * 2e-300)


def test_loss_errors():
    with pytest.raises(ValueError, match=r"same shape.*\(2,\) and \(3,\)"):
        mse([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"labels must lie in 0..1 \(2 classes\), got \[2\]"):
        cross_entropy_with_logits(np.zeros((2, 2)), [0, 2])
    with pytest.raises(ValueError, match=r"got \[-1\]"):
        cross_entropy_with_logits([[0.5, 0.5]], [-1])
    with pytest.raises(ValueError, match=r"labels must have shape \(2,\)"):
        cross_entropy_with_logits(np.zeros((2, 2)), [0, 1, 1])
    with pytest.raises(TypeError, match="labels must be integers"):
        cross_entropy_with_logits(np.zeros((2, 2)), [0.0, 1.0])
    with pytest.raises(ValueError, match=r"shape \(batch, classes\)"):
        cross_entropy_with_logits(np.zeros(3), [0, 1, 2])
    with pytest.raises(ValueError, match="finite"):
        mse([np.nan], [0.0])


def test_accuracy():
    assert accuracy(np.array([0, 1, 2, 2]), [0, 1, 1, 2]) == 0.75
    assert accuracy([[0.1, 0.9], [0.8, 0.2]], [1, 1]) == 0.5
    assert accuracy([[0.2], [0.7]], [0, 1], threshold=0.5) == 1.0
    assert accuracy([-0.1, 0.3, 2.0], [1, 1, 1], threshold=0.0) == pytest.approx(2 / 3)
    with pytest.raises(TypeError, match="pass threshold"):
        accuracy([0.2, 0.7], [0, 1])
    with pytest.raises(ValueError, match=">= 2 columns"):
        accuracy([[0.2], [0.7]], [0, 1])
    with pytest.raises(ValueError, match=r"labels must have shape \(2,\)"):
        accuracy([[0.2, 0.8], [0.7, 0.3]], [0, 1, 1])
    with pytest.raises(ValueError, match="labels must lie in 0..1"):
        accuracy([[0.2, 0.8]], [3])


# ---------------------------------------------------------------------------------------------
# optimisers


def test_sgd_with_momentum_two_steps_by_hand():
    lr, mu = 0.1, 0.9
    p0 = np.array([1.0, -2.0])
    g1, g2 = np.array([0.5, -1.0]), np.array([0.1, 0.2])
    opt = SGD(lr, momentum=mu)
    p1 = opt.step(p0, g1)
    # v1 = g1 = (0.5, -1.0); p1 = p0 - 0.1 v1
    np.testing.assert_allclose(p1, [0.95, -1.9], rtol=1e-15)
    p2 = opt.step(p1, g2)
    # v2 = 0.9 v1 + g2 = (0.55, -0.7); p2 = p1 - 0.1 v2
    np.testing.assert_allclose(p2, [0.95 - 0.055, -1.9 + 0.07], rtol=1e-14)
    # equals the textbook form u <- mu u - lr g, p <- p + u
    u = np.zeros(2)
    q = p0.copy()
    for g in (g1, g2):
        u = mu * u - lr * g
        q = q + u
    np.testing.assert_allclose(p2, q, rtol=1e-14)
    assert SGD(0.5).step([1.0], [2.0])[0] == 0.0


def test_adam_two_steps_by_hand():
    lr, b1, b2, eps = 0.1, 0.9, 0.999, 1e-8
    p0 = [1.0, -2.0]
    g1, g2 = [0.5, -1.0], [0.1, 0.2]
    opt = Adam(lr=lr, betas=(b1, b2), eps=eps)
    p1 = opt.step(np.array(p0), np.array(g1))
    # first step: m_hat = g, v_hat = g^2, so the update is lr * g / (|g| + eps) ~ lr * sign(g)
    np.testing.assert_allclose(p1, [0.9, -1.9], rtol=0, atol=1e-8)
    p2 = opt.step(p1, np.array(g2))
    for i in range(2):
        m1 = (1 - b1) * g1[i]
        v1 = (1 - b2) * g1[i] ** 2
        q1 = p0[i] - lr * (m1 / (1 - b1)) / (math.sqrt(v1 / (1 - b2)) + eps)
        m2 = b1 * m1 + (1 - b1) * g2[i]
        v2 = b2 * v1 + (1 - b2) * g2[i] ** 2
        q2 = q1 - lr * (m2 / (1 - b1**2)) / (math.sqrt(v2 / (1 - b2**2)) + eps)
        assert p1[i] == pytest.approx(q1, rel=1e-14)
        assert p2[i] == pytest.approx(q2, rel=1e-14)
    # component 0 worked out on paper: m2 = 0.055, m_hat = 0.055 / 0.19,
    # v2 = 0.00025975, v_hat = 0.00025975 / 0.001999 -> update 0.0803046...
    assert p1[0] - p2[0] == pytest.approx(0.1 * (0.055 / 0.19) / math.sqrt(0.00025975 / 0.001999))
    assert opt.t == 2


def test_rmsprop_two_steps_by_hand():
    opt = RMSprop(lr=0.01, rho=0.9, eps=1e-8)
    p1 = opt.step(np.array([1.0]), np.array([2.0]))
    s1 = 0.1 * 4.0
    assert p1[0] == pytest.approx(1.0 - 0.01 * 2.0 / (math.sqrt(s1) + 1e-8), rel=1e-14)
    p2 = opt.step(p1, np.array([-1.0]))
    s2 = 0.9 * s1 + 0.1 * 1.0
    assert p2[0] == pytest.approx(p1[0] + 0.01 / (math.sqrt(s2) + 1e-8), rel=1e-14)


@pytest.mark.parametrize(
    "opt", [Adam(lr=0.05), SGD(0.05, momentum=0.8), RMSprop(lr=0.01)], ids=repr
)
def test_optimisers_minimise_a_quadratic(opt):
    rng = np.random.default_rng(0)
    M = rng.normal(size=(4, 4))
    A = M @ M.T + np.eye(4)  # positive definite
    c = rng.normal(size=4)
    x = np.zeros(4)
    for _ in range(3000):
        x = opt.step(x, A @ (x - c))
    np.testing.assert_allclose(x, c, atol=2e-2)


def test_step_is_pure_and_state_is_internal():
    opt = Adam(lr=0.1)
    p, g = np.array([1.0, 2.0]), np.array([0.3, -0.3])
    p_copy, g_copy = p.copy(), g.copy()
    out = opt.step(p, g)
    assert out is not p
    np.testing.assert_array_equal(p, p_copy)
    np.testing.assert_array_equal(g, g_copy)
    state = opt.state_dict()
    state["m"][0] = 99.0  # a copy: does not reach the optimiser
    assert opt.m[0] != 99.0


@pytest.mark.parametrize("suffix", [".npz", ".json"])
@pytest.mark.parametrize(
    "make", [lambda: Adam(0.01, betas=(0.8, 0.99)), lambda: SGD(0.1, 0.5), lambda: RMSprop(0.02)]
)
def test_optimiser_state_round_trip_through_files(tmp_path, suffix, make):
    rng = np.random.default_rng(4)
    a = make()
    x = rng.normal(size=3)
    for _ in range(3):
        x = a.step(x, rng.normal(size=3))
    path = tmp_path / f"opt{suffix}"
    save_parameters(path, **a.state_dict())
    b = make()
    b.lr = 0.5  # overwritten by the load
    b.load_state_dict(load_parameters(path))
    assert b.lr == a.lr and b.t == 3
    g = rng.normal(size=3)
    np.testing.assert_array_equal(a.step(x, g), b.step(x, g))


def test_optimiser_reset_and_fresh_state():
    opt = Adam()
    s0 = opt.state_dict()
    assert s0["t"] == 0 and s0["m"].shape == (0,)
    opt.step(np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match=r"params must have shape \(3,\).*reset\(\)"):
        opt.step(np.zeros(2), np.ones(2))
    opt.reset()
    assert opt.t == 0
    opt.step(np.zeros(2), np.ones(2))  # a new size after reset is fine
    fresh = Adam()
    fresh.load_state_dict(s0)
    np.testing.assert_array_equal(
        fresh.step(np.zeros(2), np.ones(2)), Adam().step(np.zeros(2), np.ones(2))
    )


def test_optimiser_errors():
    with pytest.raises(ValueError, match=r"lr must lie in \(0, inf\), got 0"):
        SGD(0)
    with pytest.raises(ValueError, match="lr must lie in"):
        Adam(lr=float("nan"))
    with pytest.raises(TypeError, match="lr must be a real number"):
        Adam(lr="0.1")
    with pytest.raises(ValueError, match=r"momentum must lie in \[0, 1\), got 1"):
        SGD(0.1, momentum=1.0)
    with pytest.raises(ValueError, match=r"betas\[1\] must lie in \[0, 1\)"):
        Adam(betas=(0.9, 1.0))
    with pytest.raises(TypeError, match="betas must be a pair"):
        Adam(betas=0.9)
    with pytest.raises(ValueError, match=r"eps must lie in \(0, inf\)"):
        Adam(eps=0.0)
    with pytest.raises(ValueError, match=r"rho must lie in \[0, 1\)"):
        RMSprop(rho=-0.1)
    opt = Adam()
    with pytest.raises(ValueError, match=r"grads must have shape \(2,\)"):
        opt.step(np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="grads must be finite"):
        opt.step(np.zeros(2), np.array([0.0, np.nan]))
    with pytest.raises(ValueError, match="flat 1-d vector"):
        opt.step(np.zeros((2, 2)), np.zeros((2, 2)))
    opt.lr = 0.01
    with pytest.raises(ValueError, match="lr must lie"):
        opt.lr = -1.0
    assert opt.lr == 0.01
    state = Adam().state_dict()
    with pytest.raises(ValueError, match="must have keys"):
        SGD(0.1).load_state_dict(state)
    bad = dict(state, t=2)
    with pytest.raises(ValueError, match="does not match buffers"):
        Adam().load_state_dict(bad)
    bad = dict(state, t=1, m=np.zeros(2), v=np.zeros(3))
    with pytest.raises(ValueError, match="equal sizes"):
        Adam().load_state_dict(bad)
    bad = dict(state, beta1=1.5)
    target = Adam(lr=0.3)
    with pytest.raises(ValueError, match=r"betas\[0\] must lie"):
        target.load_state_dict(bad)
    assert target.lr == 0.3  # nothing changed by a refused load


# ---------------------------------------------------------------------------------------------
# parameter files


@pytest.mark.parametrize("name", ["params.npz", "params.json", "params.bin"])
def test_save_load_round_trip(tmp_path, name):
    rng = np.random.default_rng(9)
    arrays = {
        "0.W": rng.normal(size=(3, 2)),
        "0.b": np.array([1e-300, -np.pi]),
        "t": 7,
        "flag": np.array([True, False]),
        "empty": np.zeros(0),
        "file": np.arange(3),  # keywords of numpy.savez are ordinary names here
        "allow_pickle": np.array(1.5),
        "path": np.array(2.5),
    }
    path = tmp_path / name
    save_parameters(path, **arrays)
    assert path.exists()  # written exactly where asked (no suffix appended)
    out = load_parameters(str(path))
    assert list(out) == list(arrays)
    if name.endswith(".npz"):  # plain numpy archive, readable without qdensity or pickle
        with np.load(path, allow_pickle=False) as archive:
            np.testing.assert_array_equal(archive["0.W"], arrays["0.W"])
    for key, value in arrays.items():
        value = np.asarray(value)
        assert out[key].dtype == value.dtype and out[key].shape == value.shape
        np.testing.assert_array_equal(out[key], value)


def test_save_load_model_parameters(tmp_path):
    net = Linear(3, 4, seed=0)
    save_parameters(tmp_path / "m.npz", **net.params)
    other = Linear(3, 4, seed=5)
    loaded = load_parameters(tmp_path / "m.npz")
    set_flat(other, get_flat(loaded))
    X = np.random.default_rng(0).normal(size=(2, 3))
    np.testing.assert_array_equal(other.forward(X), net.forward(X))


def test_loading_pickle_requiring_files_fails(tmp_path):
    obj_file = tmp_path / "obj.npz"
    np.savez(obj_file, W=np.array([{"a": 1}], dtype=object))  # needs pickle
    with pytest.raises(ValueError, match="without pickle"):
        load_parameters(obj_file)
    pkl_file = tmp_path / "raw.npz"
    with open(pkl_file, "wb") as fh:
        pickle.dump({"W": np.zeros(2)}, fh)
    with pytest.raises(ValueError, match="without pickle"):
        load_parameters(pkl_file)
    npy_file = tmp_path / "single.npy"
    np.save(npy_file, np.zeros(2))
    with pytest.raises(ValueError, match="not an .npz archive"):
        load_parameters(npy_file)


def test_save_errors(tmp_path):
    with pytest.raises(TypeError, match="without pickle"):
        save_parameters(tmp_path / "a.npz", W=np.array([object()], dtype=object))
    with pytest.raises(TypeError, match="complex"):
        save_parameters(tmp_path / "a.npz", W=np.array([1j]))
    with pytest.raises(ValueError, match="NaN or inf"):
        save_parameters(tmp_path / "a.json", W=np.array([np.nan]))
    with pytest.raises(ValueError, match="name 'a/b' is not allowed"):
        save_parameters(tmp_path / "a.npz", **{"a/b": np.zeros(1)})
    (tmp_path / "x.json").write_text('{"W": [1, 2]}')
    with pytest.raises(ValueError, match="not a 'qdensity-parameters' JSON file"):
        load_parameters(tmp_path / "x.json")


# ---------------------------------------------------------------------------------------------
# composition: a tiny classifier trains


