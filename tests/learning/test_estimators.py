"""The scikit-learn estimators behave like scikit-learn's own: ``check_estimator``, ``clone``,
``Pipeline``, ``GridSearchCV`` (also with ``n_jobs=2``), ``cross_val_score``, pickling,
validation in ``fit``, per-epoch callbacks, saving, and the PCA data path against an oracle."""

import io
import pickle
import sys

import numpy as np
import pytest
from qiskit import QuantumCircuit
from sklearn.base import clone
from sklearn.datasets import load_digits, make_blobs
from sklearn.decomposition import PCA
from sklearn.model_selection import GridSearchCV, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

from qdensity import QNNClassifier as TopLevelClassifier
from qdensity.circuits.ansatze import round_robin
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.learning.estimators import QNNClassifier, QNNRegressor
from qdensity.learning.training import QNNClassifier as OldPathClassifier
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments
from qdensity.models.mixtures import SoftmaxMixture, softmax


@parametrize_with_checks([QNNClassifier(verbose=False), QNNRegressor(verbose=False)])
def test_sklearn_compatible_estimator(estimator, check):
    # every check passes: no expected failures are declared
    check(estimator)


def _blobs(num=60, seed=0):
    X, y = make_blobs(n_samples=num, centers=3, n_features=3, random_state=seed)
    return X, y


def test_old_import_paths_are_the_new_classes():
    assert OldPathClassifier is QNNClassifier is TopLevelClassifier


def test_constructor_stores_only_and_clone_copies():
    template = DensityQNN(by_moments(round_robin(3)).sub_unitaries,
                          SoftmaxMixture(3), encoding=Encoding.unary(3),
                          readout="unary_probabilities", seed=1)
    est = QNNClassifier(template, learning_rate=-3.0, gradient="nope")  # no validation here
    assert est.get_params()["model"] is template
    copy = clone(est)
    assert copy.get_params()["learning_rate"] == -3.0 and copy.model is not template
    X, y = _blobs()
    theta = template.theta.copy()
    QNNClassifier(template, epochs=2, verbose=False).fit(X, y)
    np.testing.assert_array_equal(template.theta, theta)  # the template is never mutated


def test_pipeline_grid_search_and_cross_validation():
    X, y = _blobs(90)
    pipe = make_pipeline(StandardScaler(), QNNClassifier(epochs=8, verbose=False))
    assert pipe.fit(X, y).score(X, y) > 0.8
    grid = GridSearchCV(QNNClassifier(epochs=4, verbose=False),
                        {"learning_rate": [0.01, 0.1], "decomposition": ["layers", "none"]},
                        cv=2)
    grid.fit(StandardScaler().fit_transform(X), y)
    assert set(grid.best_params_) == {"learning_rate", "decomposition"}
    assert len(grid.cv_results_["mean_test_score"]) == 4
    scores = cross_val_score(QNNRegressor(epochs=3, verbose=False), X, X[:, 0], cv=3)
    assert scores.shape == (3,) and np.all(np.isfinite(scores))


def test_grid_search_with_two_worker_processes_matches_one():
    X, y = _blobs(60)
    X = StandardScaler().fit_transform(X)
    grid = {"learning_rate": [0.02, 0.2]}
    one = GridSearchCV(QNNClassifier(epochs=3, verbose=False), grid, cv=2).fit(X, y)
    two = GridSearchCV(QNNClassifier(epochs=3, verbose=False), grid, cv=2, n_jobs=2).fit(X, y)
    np.testing.assert_allclose(two.cv_results_["mean_test_score"],
                               one.cv_results_["mean_test_score"])


def test_fitted_estimator_pickles():
    X, y = _blobs()
    clf = QNNClassifier(mixture="moe", epochs=2, verbose=False).fit(X, y)
    back = pickle.loads(pickle.dumps(clf))
    np.testing.assert_array_equal(back.predict_proba(X), clf.predict_proba(X))


def test_pca_data_path_against_an_oracle():
    """num_qubits with PCA: logits = W^T f([PCA(x), c]) + b with f the exact model (eq. 3)
    (scale=False: the PCA of the raw pixels; the standardised path: tests/learning/
    test_estimate.py)."""
    X, y = load_digits(return_X_y=True)
    X, y = X[:40], y[:40]
    clf = QNNClassifier(num_qubits=6, constant=2.0, scale=False, epochs=2,
                        verbose=False).fit(X, y)
    assert clf.model_.num_qubits == 6 and clf.pca_.n_components_ == 5
    pca = PCA(5, svd_solver="full").fit(X)
    Z = np.hstack([pca.transform(X), np.full((len(X), 1), 2.0)])
    f = clf.model_.predict(Z, method="statevector")  # Aer statevectors, not the unary engine
    logits = f @ clf.post_.params["W"] + clf.post_.params["b"]
    np.testing.assert_allclose(clf.predict_proba(X), softmax(logits), atol=1e-8)


def test_per_epoch_callbacks_with_test_metric_and_shots():
    X, y = _blobs(12)
    X = StandardScaler().fit_transform(X)
    seen = []

    def cb(est, record):
        seen.append((record["epoch"], est.score(X[:6], y[:6])))
        return record["epoch"] == 2  # stop after the third epoch

    engine = SamplerEngine(seed=3)
    clf = QNNClassifier(epochs=10, batch_size=6, engine=engine, shots=10, verbose=False,
                        gradient="commuting", callbacks=[cb])
    clf.fit(X, y, eval_set=(X[:6], y[:6]))
    epochs = clf.history_.epochs
    assert [r["epoch"] for r in epochs] == [0, 1, 2]
    assert [r["test_metric"] for r in epochs] == [s for _, s in seen]
    shots = [r["shots"] for r in epochs]
    assert shots[-1] == engine.ledger.total_shots > 0 and shots == sorted(shots)
    assert epochs[-1]["step"] == len(clf.history_) == 6


def test_progress_bar_only_on_a_terminal(monkeypatch):
    X, y = _blobs(30)
    import functools

    from qdensity import progress

    # draw on every step (tqdm redraws at most every 0.1 s by default)
    monkeypatch.setattr(progress, "tqdm", functools.partial(progress.tqdm, mininterval=0))

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for verbose, stream, shown in ((True, Terminal(), True), (False, Terminal(), False),
                                   (True, io.StringIO(), False)):
        monkeypatch.setattr(sys, "stderr", stream)
        QNNClassifier(epochs=2, verbose=verbose).fit(X, y)
        text = stream.getvalue()
        assert ("QNNClassifier" in text and "loss=" in text and "shots=" in text) == shown


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_save_load_restores_predict_and_refuses_other_versions(tmp_path, suffix):
    X, y = _blobs()
    labels = np.array(["ant", "bee", "cat"])[y]
    clf = QNNClassifier(num_qubits=3, mixture="moe_gelu", epochs=2, verbose=False)
    clf.fit(X, labels)
    path = tmp_path / f"clf{suffix}"
    clf.save(path)
    fresh = QNNClassifier().load(path)  # spec, classes_, PCA and parameters from the file
    np.testing.assert_array_equal(fresh.predict(X), clf.predict(X))
    np.testing.assert_allclose(fresh.predict_proba(X), clf.predict_proba(X), atol=1e-12)
    with pytest.raises(ValueError, match="QNNClassifier, not a QNNRegressor"):
        QNNRegressor().load(path)
    import json

    from qdensity.learning.parameters import load_parameters, save_parameters

    data = load_parameters(path)
    meta = json.loads(bytes(data["meta"]).decode())
    meta["version"] = 99
    data["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    save_parameters(path, **data)
    with pytest.raises(ValueError, match="version 99"):
        QNNClassifier().load(path)
    save_parameters(path, W=np.ones(3))
    with pytest.raises(ValueError, match="not a saved qdensity estimator"):
        QNNClassifier().load(path)


def test_regressor_multi_output_and_save(tmp_path):
    X = np.random.default_rng(1).normal(size=(40, 3))
    Y = np.stack([X[:, 0], X[:, 1] ** 2], axis=1)
    reg = QNNRegressor(epochs=3, verbose=False).fit(X, Y)
    assert reg.predict(X).shape == (40, 2)
    reg.save(tmp_path / "r.npz")
    np.testing.assert_allclose(QNNRegressor().load(tmp_path / "r.npz").predict(X),
                               reg.predict(X), atol=1e-12)


@pytest.mark.parametrize(("params", "error", "match"), [
    ({"learning_rate": float("nan")}, ValueError, "learning_rate"),
    ({"learning_rate": -0.1}, ValueError, "learning_rate"),
    ({"learning_rate": "fast"}, TypeError, "learning_rate"),
    ({"gradient": "adjoint-ish"}, ValueError, "gradient"),
    ({"max_shots": -5}, ValueError, "max_shots"),
    ({"decomposition": "slices"}, ValueError, "decomposition"),
    ({"ansatz": "brickwork"}, ValueError, "ansatz"),
    ({"mixture": "gumbel"}, ValueError, "mixture"),
    ({"optimizer": "lbfgs"}, ValueError, "optimizer"),
    ({"epochs": 0}, ValueError, "epochs"),
    ({"l2": -1.0}, ValueError, "l2"),
    ({"engine": "gpu"}, ValueError, "engine"),
    ({"engine": SamplerEngine(seed=0)}, ValueError, "shots"),
    ({"num_qubits": 1}, ValueError, "num_qubits"),
    ({"constant": None, "num_qubits": None}, ValueError, "unary encoding needs at least 2"),
    ({"callbacks": [3]}, TypeError, "callbacks"),
    ({"post": "mlp"}, ValueError, "post"),
    ({"model": "round_robin"}, TypeError, "model"),
])
def test_bad_hyperparameters_are_refused_in_fit(params, error, match):
    est = QNNClassifier(verbose=False, **params)  # stored as given
    X1 = np.random.default_rng(0).normal(size=(10, 1))
    with pytest.raises(error, match=match):
        est.fit(X1, np.arange(10) % 2)


def test_bad_data_and_unknown_names():
    X, y = _blobs(20)
    with pytest.raises(ValueError, match="Invalid parameter 'learnig_rate'"):
        QNNClassifier().set_params(learnig_rate=0.1)
    with pytest.raises(ValueError, match="0 sample"):
        QNNClassifier(verbose=False).fit(np.zeros((0, 3)), [])
    with pytest.raises(ValueError, match="at least 2 classes"):
        QNNClassifier(verbose=False).fit(X, np.zeros(20))
    with pytest.raises(ValueError, match="expecting 3 features"):
        QNNClassifier(epochs=1, verbose=False).fit(X, y).predict(X[:, :2])
    frozen = DensityQNN([QuantumCircuit(3)], encoding=Encoding.unary(3),
                        readout="unary_probabilities")
    with pytest.raises(ValueError, match="no trainable parameters"):
        QNNClassifier(frozen, verbose=False).fit(X, y)


def test_one_output_model_without_head_names_both_fixes():
    """Issue "first hour": a one-output (observable) model cannot classify without a head; the
    error says what to do: a read-out head, or one output per class."""
    from qiskit.quantum_info import SparsePauliOp

    X, y = make_blobs(20, n_features=4, centers=2, random_state=0)
    model = DensityQNN([round_robin(4)], encoding=Encoding.unary(4),
                       observable=SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4))
    clf = QNNClassifier(model=model, post=None, epochs=1, verbose=False)
    with pytest.raises(ValueError, match=r"1 output\(s\).*post='linear'.*unary_probabilities"):
        clf.fit(X, y)
    clf.set_params(post="linear").fit(X, y)  # the first fix works
    assert clf.predict(X).shape == (20,)
