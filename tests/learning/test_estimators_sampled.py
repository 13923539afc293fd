"""Estimators trained with a seeded :class:`SamplerEngine`: refits give the same model, a
fitted estimator pickles (``pickle``, ``joblib``) and deep-copies with equal behaviour, and
after ``GridSearchCV`` the shots are where the docs say (each fitted clone's engine ledger)."""

from __future__ import annotations

import copy
import io
import pickle

import joblib
import numpy as np
import pytest
from sklearn.base import clone
from sklearn.datasets import make_blobs
from sklearn.model_selection import GridSearchCV
from sklearn.preprocessing import StandardScaler

from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.learning.estimators import QNNClassifier


def _data():
    X, y = make_blobs(n_samples=12, centers=2, n_features=3, random_state=0)
    return StandardScaler().fit_transform(X), y


def _model(clf, X):
    """What the fitted model computes (exactly, whatever engine trained it)."""
    return clf.predict_proba(X)


def _clf(engine, seed=0, **kw):
    return QNNClassifier(epochs=1, batch_size=6, engine=engine, shots=16, verbose=False,
                         gradient="commuting", seed=seed, **kw)


def test_refit_with_a_seeded_sampler_engine_is_idempotent_and_counted():
    X, y = _data()
    engine = SamplerEngine(seed=0, progress=False)
    clf = _clf(engine).fit(X, y)
    first = _model(clf, X)
    spent = engine.ledger.total_shots
    assert spent > 0 and clf.history_["shots"][-1] == spent
    clf.fit(X, y)
    np.testing.assert_array_equal(_model(clf, X), first)
    assert engine.ledger.total_shots == 2 * spent  # both fits on the engine's ledger
    # another estimator seed, or another engine seed: other shots, another model
    other = _clf(SamplerEngine(seed=0, progress=False), seed=1).fit(X, y)
    assert not np.array_equal(_model(other, X), first)
    other = _clf(SamplerEngine(seed=1, progress=False)).fit(X, y)
    assert not np.array_equal(_model(other, X), first)


def _round_trips():
    def joblib_trip(obj):
        buf = io.BytesIO()
        joblib.dump(obj, buf)
        buf.seek(0)
        return joblib.load(buf)

    return {"pickle": lambda o: pickle.loads(pickle.dumps(o)), "joblib": joblib_trip,
            "deepcopy": copy.deepcopy}


@pytest.mark.parametrize("trip", sorted(_round_trips()))
def test_fitted_estimator_with_sampler_engine_round_trips(trip):
    X, y = _data()
    clf = _clf(SamplerEngine(seed=0, progress=False)).fit(X, y)
    twin = _round_trips()[trip](clf)
    np.testing.assert_array_equal(twin.predict_proba(X), clf.predict_proba(X))
    # its engine draws the same shots as the original's for the same next estimate
    a = twin.estimate(X[:2], engine=twin.engine, shots=50)
    b = clf.estimate(X[:2], engine=clf.engine, shots=50)
    np.testing.assert_array_equal(a.value, b.value)
    # refitting the copy gives the original's model
    np.testing.assert_array_equal(_model(twin.fit(X, y), X), _model(clf, X))


def test_grid_search_shots_are_on_the_fitted_clones_ledgers():
    X, y = _data()
    engine = SamplerEngine(seed=0, progress=False)
    search = GridSearchCV(_clf(engine), {"learning_rate": [0.05, 0.1]}, cv=2).fit(X, y)
    # clone deep-copies the engine with its ledger: the engine passed in spent nothing ...
    assert engine.ledger.total_shots == 0
    best = search.best_estimator_
    assert best.engine is not engine
    # ... and the refit's shots are on the best estimator's engine ledger
    assert best.engine.ledger.total_shots == best.history_["shots"][-1] > 0
    # the same search twice: the same scores (every fit reseeded from its seeds)
    again = GridSearchCV(_clf(engine), {"learning_rate": [0.05, 0.1]}, cv=2).fit(X, y)
    np.testing.assert_array_equal(search.cv_results_["mean_test_score"],
                                  again.cv_results_["mean_test_score"])


def test_clone_of_a_fitted_estimator_refits_to_the_same_model():
    X, y = _data()
    clf = _clf(SamplerEngine(seed=2, progress=False)).fit(X, y)
    twin = clone(clf).fit(X, y)
    np.testing.assert_array_equal(_model(twin, X), _model(clf, X))
