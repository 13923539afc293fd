"""Training loop: gradients of the whole pipeline against finite differences, sampled runs with
an honest ledger and budget, reproducibility, saving and loading."""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from _stats import unary_input_vjp_sd

from qdensity.circuits.ansatze import round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.inputs import input_gradient_plan, loader_angles_jacobian
from qdensity.learning import losses
from qdensity.learning.nn import Linear
from qdensity.learning.training import QNNClassifier, QNNRegressor, QuantumLayer
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments
from qdensity.models.mixtures import SoftmaxMixture

RNG = np.random.default_rng(5)


def _model(n=4, seed=0, readout="unary_probabilities"):
    dec = by_moments(round_robin(n))
    return DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries),
                      encoding=Encoding.unary(n), readout=readout, seed=seed)


def _blobs(num=40, n=4, seed=0):
    rng = np.random.default_rng(seed)
    y = rng.integers(0, 2, num)
    centers = np.array([[2.0, 0.5, 0.1, 0.1], [0.1, 0.1, 0.5, 2.0]])[:, :n]
    return centers[y] + 0.3 * rng.normal(size=(num, n)), y


def test_pipeline_gradient_matches_finite_differences():
    """pre Linear -> quantum layer (unary reverse mode) -> post Linear -> CE loss."""
    n = 4
    model = _model(n, seed=1)
    pre = Linear(n, n, seed=2)
    pre.params["b"][:] = 1.0  # keep rows away from zero
    X = RNG.normal(size=(5, n)) * 0.3 + 1.0
    y = np.array([0, 1, 2, 1, 0])
    est = QNNClassifier(model, pre=pre, post=Linear(n, 3, seed=3), verbose=False,
                        max_steps=1).fit(X, y)

    def loss_at(flat):
        est._set(flat)
        return losses.cross_entropy_with_logits(est._forward(X), y)[0]

    flat = est._get()
    out = est._forward(X)
    _, g = losses.cross_entropy_with_logits(out, y)
    est._backward(g)
    grad = est._grads()
    h = 1e-6
    steps = np.eye(flat.size) * h
    fd = np.array([(loss_at(flat + e) - loss_at(flat - e)) / (2 * h) for e in steps])
    est._set(flat)
    np.testing.assert_allclose(grad, fd, atol=1e-6)


def test_exact_training_reduces_loss_and_is_reproducible():
    X, y = _blobs()
    runs = []
    for _ in range(2):
        clf = QNNClassifier(_model(seed=3), post=Linear(4, 2, seed=0), learning_rate=0.1,
                            epochs=15, batch_size=10, seed=42, verbose=False).fit(X, y)
        runs.append(clf)
    loss = runs[0].history_["loss"]
    assert loss[-4:].mean() < loss[:4].mean()
    assert runs[0].score(X, y) >= 0.8
    np.testing.assert_array_equal(runs[0].history_["loss"], runs[1].history_["loss"])
    assert runs[0].history_["shots"].max() == 0  # exact: no shots


def test_sampled_training_ledger_and_budget():
    X, y = _blobs(num=16)
    model = _model(seed=4)
    engine = SamplerEngine(seed=9)
    budget = 20_000
    clf = QNNClassifier(model, post=Linear(4, 2, seed=0), learning_rate=0.1, epochs=50,
                        batch_size=4, engine=engine, shots=50, gradient="commuting", seed=1,
                        verbose=False, max_shots=budget).fit(X, y)
    assert clf.stopped_by_budget_
    assert engine.ledger.total_shots <= budget
    assert clf.history_["shots"][-1] == engine.ledger.total_shots
    # per step: batch * (K commuting gradient circuits + K forward circuits) * shots
    K = model.num_subunitaries
    per_step = 4 * (K + K) * 50
    assert engine.ledger.total_shots == per_step * len(clf.history_)
    assert np.all(np.diff(clf.history_["circuits"]) == 4 * 2 * K)



def test_sampled_step_is_unbiased_against_exact():
    """One sampled gradient step equals the exact gradient within standard errors."""
    X, y = _blobs(num=4)
    exact = QNNClassifier(_model(seed=5), post=Linear(4, 2, seed=0), verbose=False,
                          learning_rate=1e-12, max_steps=1).fit(X, y)
    out = exact._forward(X)
    _, g = losses.cross_entropy_with_logits(out, y)
    exact._backward(g)
    g_exact = exact.layer_.grads["theta"]
    layer = QuantumLayer(_model(seed=5), SamplerEngine(seed=_stat_seed(3)), shots=20000,
                         gradient="commuting")
    out_s = layer.forward(X)
    # 16 probability estimates of 20000 shots each, sd <= sqrt(0.25 / 20000) = 0.0035: 0.03 is
    # 8.5 sd (false failure < 1e-15)
    assert np.abs(out_s - exact.layer_.forward(X)).max() < 0.03
    layer.backward(exact.post_.backward(losses.cross_entropy_with_logits(
        exact.post_.forward(out_s), y)[1]))
    # each theta entry is sum_{rows, outputs} g * (an estimate of a probability or a difference
    # of two, variance <= 2 / shots), g = dloss/dout with sum g^2 ~ 2e-3 here: sd ~ 0.002, so
    # 0.05 is > 20 sd beside the change of g through the sampled forward (|g'| |out_s - out|
    # < 0.03): false failure < 1e-6 (the rate listed in benchmarks/fuzz_statistics.py)
    assert np.abs(layer.grads["theta"] - g_exact).max() < 0.05


def test_pre_layer_trains_on_a_sampler_with_sampled_input_gradients():
    """A trainable pre layer in front of the quantum layer on a SamplerEngine: two steps run,
    every shot (the input-gradient circuits' too) on the ledger; the pre layer's sampled
    gradient (the loader's shift circuits chained to it) within a derived bound of the exact
    one."""
    n, shots = 4, 2000
    X, y = _blobs(num=8, n=n)
    pre = Linear(n, n, seed=1)
    pre.params["b"][:] = 1.0  # keep rows away from zero
    engine = SamplerEngine(seed=_stat_seed(21))
    est = QNNClassifier(_model(n, seed=6), pre=pre, post=Linear(n, 2, seed=0), engine=engine,
                        shots=shots, batch_size=4, max_steps=2, learning_rate=0.1,
                        verbose=False).fit(X, y)
    assert len(est.history_) == 2
    assert est.history_["shots"][-1] == engine.ledger.total_shots
    meta = input_gradient_plan(est.model_, X[:4]).meta["input_circuits"]
    spent = sum(s for label, (_, s) in engine.ledger.by_label().items()
                if label.startswith("input_gradient"))
    assert spent == 2 * 4 * meta * shots  # two steps of four rows
    assert not np.allclose(est.pre_.params["W"], pre.params["W"])  # it trained
    # max_shots covers the input-gradient circuits: a budget of 1.5 steps stops after one (the
    # density circuits alone, forward and one commuting circuit per sub-unitary, cost less
    # than half a step here, so a budget check that left the input circuits out would run two)
    step = engine.ledger.total_shots // 2
    assert spent // 2 > step // 2
    capped = QNNClassifier(_model(n, seed=6), pre=pre, post=Linear(n, 2, seed=0),
                           engine=SamplerEngine(seed=0), shots=shots, batch_size=4,
                           max_steps=2, max_shots=3 * step // 2, verbose=False).fit(X, y)
    assert capped.stopped_by_budget_ and len(capped.history_) == 1
    # one backward with a fixed upstream G (linear in the estimates): exact, then sampled
    Xb, G = X[:4], RNG.normal(size=(4, 2))
    grads = {}
    for name, layer in (("exact", QuantumLayer(est.model_, "exact")),
                        ("sampled", QuantumLayer(est.model_, SamplerEngine(seed=_stat_seed(22)),
                                                 shots=shots, input_gradients=True))):
        est.layer_ = layer
        est._forward(Xb)
        est._backward(G)
        grads[name] = {k: v.copy() for k, v in est.pre_.grads.items()}
    Z = est.pre_.forward(Xb)
    upstream = G @ est.post_.params["W"].T  # dL/dF, F the quantum layer's output
    sd_z = unary_input_vjp_sd(est.model_.alpha(Z), loader_angles_jacobian(Z), upstream, shots)
    # grads W = Xb^T dL/dZ, b = sum_rows dL/dZ; rows use independent circuits
    sd = {"W": np.sqrt((Xb**2).T @ sd_z**2), "b": np.sqrt((sd_z**2).sum(axis=0))}
    # 16 + 4 entries, each normal with sd below its bound, within 5 of it:
    # false failure <= 20 x 2 Phi(-5) = 1.2e-5
    for key in ("W", "b"):
        assert np.all(np.abs(grads["sampled"][key] - grads["exact"][key]) <= 5 * sd[key]), key
    est.layer_ = QuantumLayer(est.model_, ExactEngine())  # a plan path without input gradients
    est._forward(Xb)
    with pytest.raises(ValueError, match="input_gradients=True"):
        est._backward(G)


def test_regressor_on_observable_readout():
    n = 4
    model = _model(n, seed=2, readout="observable")
    X = RNG.normal(size=(20, n))
    target = np.tanh(X[:, 0])
    reg = QNNRegressor(model, learning_rate=0.05, epochs=10, batch_size=5, seed=0,
                       verbose=False).fit(X, target)
    assert reg.predict(X).shape == (20,)
    assert reg.history_["loss"][-3:].mean() <= reg.history_["loss"][:3].mean()


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_save_and_load_round_trip(tmp_path, suffix):
    X, y = _blobs(num=10)
    clf = QNNClassifier(_model(seed=6), post=Linear(4, 2, seed=0), epochs=2, batch_size=5,
                        seed=0, verbose=False).fit(X, y)
    path = tmp_path / f"params{suffix}"
    clf.save(path)
    fresh = QNNClassifier(_model(seed=99), post=Linear(4, 2, seed=7), verbose=False)
    fresh.load(path)  # classes_ and everything predict needs come from the file
    np.testing.assert_array_equal(fresh.classes_, clf.classes_)
    np.testing.assert_allclose(fresh.decision_function(X), clf.decision_function(X), atol=1e-12)
    np.testing.assert_array_equal(fresh.predict(X), clf.predict(X))
    other = QNNClassifier(_model(n=6, seed=0), post=Linear(6, 2, seed=0), verbose=False)
    with pytest.raises(ValueError, match="the template has 6 qubits"):
        other.load(path)


def test_bad_training_input():
    model = _model()
    with pytest.raises(ValueError, match="shots"):
        QuantumLayer(model, SamplerEngine(seed=0))
    est = QNNClassifier(model, optimizer="lbfgs")  # stored unvalidated, refused by fit
    with pytest.raises(ValueError, match="optimizer"):
        est.fit(*_blobs(num=4))
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        QNNClassifier(model, verbose=False).fit(np.ones((3, 4)), [0, 1])
