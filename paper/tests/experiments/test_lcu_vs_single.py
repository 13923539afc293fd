"""lcu-vs-single at a tiny size: output shape and invariants; oracles of its training pieces."""

import json

import numpy as np
import pytest
from _rows import assert_rerun_resumes

from qdensity.circuits.ansatze import round_robin
from qdensity.models.lcu import LCUQNN
from qdensity.models.mixtures import GatedMixture
from qdensity_paper import run
from qdensity_paper._lcu_training import accuracy, fit_epochs, nll_grad
from qdensity_paper.lcu_vs_single import load_data

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


def test_sgd_step_with_l2_is_the_finite_difference_gradient_plus_the_penalty():
    """One full-batch SGD step with l2 moves theta by -lr (dNLL/dtheta + l2 theta), the
    gradient taken by central finite differences of the loss."""
    rng = np.random.default_rng(5)
    X = rng.normal(size=(12, 3))
    y = rng.integers(0, 3, 12)
    model = LCUQNN([round_robin(3, parameter_prefix="s")], seed=3)
    theta = model.theta.copy()
    h, grad = 1e-6, np.zeros_like(theta)
    for i in range(theta.size):
        for sign in (1, -1):
            model.theta = theta + sign * h * np.eye(theta.size)[i]
            grad[i] += sign * nll_grad(model.predict(X), y)[0] / (2 * h)
    model.theta = theta
    lr, l2 = 0.1, 0.3
    fit_epochs(model, X, y, epochs=1, batch_size=12, learning_rate=lr, train="theta",
               rng=np.random.default_rng(0), optimizer="sgd", l2=l2)
    assert np.allclose(model.theta, theta - lr * (grad + l2 * theta), atol=1e-7)


@pytest.mark.parametrize("key,value", [("optimizer", "lbfgs"), ("l2", -1.0)])
def test_fit_epochs_refuses_bad_optimiser_settings(key, value):
    model = LCUQNN([round_robin(3, parameter_prefix="s")], seed=3)
    kwargs = {"optimizer": "adam", "l2": 0.0, key: value}
    with pytest.raises(ValueError, match=key):
        fit_epochs(model, np.ones((2, 3)), np.zeros(2, dtype=int), epochs=1, batch_size=2,
                   learning_rate=0.1, train="theta", rng=np.random.default_rng(0), **kwargs)


def test_sweep_units_selected_trial_and_resume_from_storage(tmp_path):
    """A 2-trial study per (model, seed): the reported accuracy is the test accuracy the
    storage holds for the trial with the best validation score, the sweep's aggregates are
    counted by hand from the trials, the shots from the training rows, and a rerun whose unit
    files are gone resumes the studies (no new trials, the same numbers)."""

    optuna = pytest.importorskip("optuna")
    from qdensity.learning.sweep import PAPER_SPACE

    config = dict(TINY, pretrain_epochs=1, lcu_epochs=1, trials=2, sampled_points=1)
    out = tmp_path / "not-yet-made"
    first = run("lcu-vs-single", seeds=[1], config=config, out=out, plot=False,
                progress=False)
    row = first.per_seed[0]
    storage = f"sqlite:///{out / 'lcu-vs-single-sweeps.db'}"
    names = sorted(optuna.get_all_study_names(storage))
    assert [n.split("-")[4] for n in names] == ["lcu", "single"]  # one study per model
    for name in names:
        m = name.split("-")[4]
        trials = optuna.load_study(study_name=name, storage=storage).trials
        assert [t.state.name for t in trials] == ["COMPLETE", "COMPLETE"]
        for t in trials:
            assert set(t.params) == set(PAPER_SPACE)
            assert 1e-4 <= t.params["learning_rate"] <= 1e-2
        best = max(trials, key=lambda t: (t.value, -t.number))
        assert row[f"{m}/test_accuracy"] == best.user_attrs["test_accuracy"]
        accs = [t.user_attrs["test_accuracy"] for t in trials]
        assert row["curves"][f"{m}/trials"]["y"] == accs
        assert row[f"{m}/runs_above"] == sum(a >= 0.8 for a in accs)
        assert row[f"{m}/mean_accuracy"] == pytest.approx(np.mean(accs))
        assert row["curves"][f"{m}/test_vs_epoch"]["y"] == best.user_attrs["test_by_epoch"]
    assert row["lcu/minus_single"] == pytest.approx(row["lcu/test_accuracy"]
                                                    - row["single/test_accuracy"])
    # 30 training rows less the 20% validation split; round robin on 3 qubits: 3 angles
    train_rows, spc = 24, 100
    single_epoch = train_rows * (4 * 3 + 1) * spc
    assert row["single/shots"] == single_epoch * 2
    assert row["curves"]["single/test_vs_epoch"]["x"] == [1.0, 2.0]
    lcu = row["curves"]["lcu/test_vs_shots"]
    assert lcu["x"][0] == 2 * single_epoch  # K = 2 sub-unitaries pretrained for one epoch
    assert row["curves"]["lcu/test_vs_epoch"]["x"] == [1.0, 2.0]  # uniform start, then the gate
    assert row["sampled/shots"] == 64
    assert_rerun_resumes(run, "lcu-vs-single", 1, config, out, storage, names, row, 2,
                         plot=False)


@pytest.mark.parametrize("key,value", [("trials", -1), ("validation_fraction", 0.6),
                                       ("validation_fraction", 1)])
def test_bad_sweep_settings_name_the_setting(key, value):
    with pytest.raises(ValueError, match=key):
        run("lcu-vs-single", config={**TINY, key: value}, seeds=1, progress=False)
