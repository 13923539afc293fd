"""lcu-vs-single at a tiny size: output shape and invariants; oracles of its training pieces."""

import json

import numpy as np
import pytest

from qdensity.ansatze import round_robin
from qdensity.experiments import run
from qdensity.experiments._lcu_training import accuracy, fit_epochs, nll_grad
from qdensity.experiments.lcu_vs_single import load_data
from qdensity.mixtures import GatedMixture
from qdensity.models.lcu import LCUQNN

TINY = {"num_qubits": 3, "train_size": 30, "test_size": 30, "pretrain_epochs": 2,
        "lcu_epochs": 2, "batch_size": 10, "sampled_points": 2, "sample_shots": 64}


@pytest.fixture(scope="module")
def result(tmp_path_factory, checked_run):
    out = tmp_path_factory.mktemp("lcu")
    return checked_run("lcu-vs-single", TINY, [0, 3], out), out


def test_seeds_metrics_and_cis(result):
    res, _ = result
    for m in res.per_seed:
        assert 0.0 <= m["lcu/test_accuracy"] <= 1.0 and 0.0 <= m["single/test_accuracy"] <= 1.0
        assert 0.0 < m["lcu/success_probability_min"] <= m["lcu/success_probability"] <= 1.0
        assert m["lcu/shot_overhead"] >= 1.0
        assert m["sampled/shots"] == 2 * 64
        assert 0.0 <= m["sampled/success_probability"] <= 1.0


def test_curves_lengths_and_shots_increasing(result):
    res, _ = result
    c = res.curves
    assert len(c["single/test_vs_epoch"]["x"]) == 4
    assert c["lcu/test_vs_epoch"]["x"] == [2.0, 3.0, 4.0]  # from the pretrained, uniform start
    assert len(c["sub_best/test_vs_epoch"]["x"]) == 2
    for name in ("single/test_vs_shots", "lcu/test_vs_shots"):
        assert np.all(np.diff(c[name]["x"]) > 0), name
    # the LCU starts after pretraining K = n - 1 circuits: its shots start above the single's
    assert c["lcu/test_vs_shots"]["x"][0] > c["single/test_vs_shots"]["x"][0]


def test_files_written(result):
    res, out = result
    data = json.loads((out / "lcu-vs-single-quick.json").read_text())
    assert data["seeds"] == [0, 3]
    assert res.figures and all((out / p.split("/")[-1]).exists() for p in res.figures)


@pytest.mark.parametrize("key,value", [("num_qubits", 2), ("lcu_epochs", 0),
                                       ("learning_rate", -1.0), ("sampled_points", -1)])
def test_bad_settings_name_the_setting(key, value):
    with pytest.raises(ValueError, match=key):
        run("lcu-vs-single", config={**TINY, key: value}, seeds=1, progress=False)


def test_load_data_classes_and_standardised():
    X_tr, X_te, y_tr, y_te = load_data(4, 50, 100, seed=1)
    assert X_tr.shape == (50, 4) and set(np.unique(y_tr)) <= {0, 1, 2, 3}
    assert set(np.unique(y_te)) <= {0, 1, 2, 3}
    assert np.allclose(X_tr.mean(axis=0), 0.0, atol=1e-10)
    assert np.allclose(X_tr.std(axis=0), 1.0, atol=1e-6)


def test_nll_grad_finite_differences_and_accuracy():
    rng = np.random.default_rng(0)
    P = rng.uniform(0.1, 1.0, size=(4, 3))
    y = np.array([0, 2, 1, 2])
    loss, g = nll_grad(P, y)
    assert loss == pytest.approx(-np.mean(np.log(P[np.arange(4), y])))
    h = 1e-6
    for i, j in [(0, 0), (1, 2), (2, 0)]:
        Q = P.copy()
        Q[i, j] += h
        assert (nll_grad(Q, y)[0] - loss) / h == pytest.approx(g[i, j], rel=1e-4, abs=1e-6)
    assert accuracy(np.eye(3)[[0, 1, 1]], np.array([0, 1, 2])) == pytest.approx(2 / 3)


def test_mixture_phase_moves_only_the_gate_and_lowers_the_loss():
    rng = np.random.default_rng(2)
    X = rng.normal(size=(40, 3))
    y = rng.integers(0, 3, 40)
    subs = [round_robin(3, parameter_prefix=f"u{k}") for k in range(2)]
    model = LCUQNN(subs, GatedMixture(3, 2, weights=np.zeros((2, 3))), seed=1)
    theta = model.theta.copy()
    before = nll_grad(model.predict(X), y)[0]
    fit_epochs(model, X, y, epochs=20, batch_size=40, learning_rate=0.05, train="mixture",
               rng=rng)
    assert np.array_equal(model.theta, theta)
    assert nll_grad(model.predict(X), y)[0] < before
