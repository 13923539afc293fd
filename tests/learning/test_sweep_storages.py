"""optuna storage objects (``RDBStorage`` on an SQLite file, ``JournalStorage`` with a file
backend, ``InMemoryStorage``) work wherever a storage URL does: ``open_study``, ``run_sweep``
(a fresh run, a resumed run, settings checked), ``run_trials``; the trials land in the given
storage (read back through optuna alone, and for the file kinds through a new storage object
on the same file); in-memory storage with a cluster and objects of other types are refused."""

import numpy as np
import pytest

optuna = pytest.importorskip("optuna")  # the optional extra; CI installs it (.ci/run)

from optuna.storages import InMemoryStorage, JournalStorage, RDBStorage  # noqa: E402
from optuna.storages.journal import JournalFileBackend  # noqa: E402
from sklearn.datasets import load_iris  # noqa: E402
from sklearn.preprocessing import StandardScaler  # noqa: E402

from qdensity.learning.estimators import QNNClassifier  # noqa: E402
from qdensity.learning.sweep import open_study, run_sweep, run_trials  # noqa: E402

SMALL = {"learning_rate": ("log", 1e-3, 1e-1)}
KINDS = ("rdb", "journal", "memory")


def _storage(kind: str, tmp_path):
    """A fresh storage object of ``kind``, and a function that opens another object on the
    same trials (a new connection to the file; the same object for memory)."""
    if kind == "rdb":
        url = f"sqlite:///{tmp_path / 'rdb.db'}"
        return RDBStorage(url), lambda: RDBStorage(url)
    if kind == "journal":
        path = str(tmp_path / "journal.log")
        return (JournalStorage(JournalFileBackend(path)),
                lambda: JournalStorage(JournalFileBackend(path)))
    memory = InMemoryStorage()
    return memory, lambda: memory


def _data():
    X, y = load_iris(return_X_y=True)
    X, y = StandardScaler().fit_transform(X)[::5], y[::5]  # 30 rows: a quick fit
    return X, y


@pytest.mark.parametrize("kind", KINDS)
def test_run_sweep_with_a_storage_object(kind, tmp_path):
    X, y = _data()
    storage, reopen = _storage(kind, tmp_path)
    est = QNNClassifier(epochs=1, verbose=False)
    study = run_sweep(X, y, est, n_trials=2, storage=storage, space=SMALL, study_name="s",
                      sampler_seed=0, verbose=False)
    # the oracle: optuna itself, on a new storage object over the same trials
    again = optuna.load_study(study_name="s", storage=reopen())
    complete = [t for t in again.trials if t.state.name == "COMPLETE"]
    assert [t.number for t in complete] == [0, 1]
    assert [t.value for t in complete] == [t.value for t in study.trials]
    assert all(0.0 <= t.value <= 1.0 for t in complete)
    # a rerun resumes: the study already has its trials, none is added
    run_sweep(X, y, est, n_trials=2, storage=reopen(), space=SMALL, study_name="s",
              verbose=False)
    assert len(optuna.load_study(study_name="s", storage=reopen()).trials) == 2
    # and the study is tied to its settings, whatever kind of storage holds it
    with pytest.raises(ValueError, match="made with other settings"):
        run_sweep(X, y, QNNClassifier(epochs=2, verbose=False), n_trials=2, storage=reopen(),
                  space=SMALL, study_name="s", verbose=False)


@pytest.mark.parametrize("kind", KINDS)
def test_open_study_and_run_trials_with_a_storage_object(kind, tmp_path):
    storage, reopen = _storage(kind, tmp_path)
    study = open_study("q", storage, n_trials=6, seed=0, direction="minimize")

    def evaluate(trial):
        x = trial.suggest_float("x", -1.0, 1.0)
        return x * x

    assert run_trials(study, evaluate, 6) == 6
    values = sorted(t.params["x"] ** 2 for t in optuna.load_study(
        study_name="q", storage=reopen()).trials)
    assert len(values) == 6
    assert values == sorted(t.value for t in study.trials)
    assert optuna.get_all_study_names(reopen()) == ["q"]


def test_storage_objects_refused_where_they_cannot_work(tmp_path):
    X, y = _data()
    with pytest.raises(ValueError, match="memory, which the cluster's workers cannot reach"):
        run_sweep(X, y, storage=InMemoryStorage(), cluster="local:1", verbose=False)
    with pytest.raises(ValueError, match="memory, which the cluster's workers cannot reach"):
        run_sweep(X, y, storage=":memory:", cluster="local:1", verbose=False)
    with pytest.raises(TypeError, match="storage.*optuna storage URL .* or storage object"):
        run_sweep(X, y, storage=np.zeros(2), verbose=False)
    with pytest.raises(TypeError, match="storage.*optuna storage URL .* or storage object"):
        open_study("s", storage=3)
