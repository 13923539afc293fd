"""optuna sweeps: two (and eight) worker processes started together on a fresh SQLite file share
one study and finish exactly N trials between them (none lost, none run twice); an interrupted
sweep keeps its finished trials and resumes; a study is tied to its settings; TPE is TPE after
a short random start; JSON and CSV export; the ``qdensity sweep`` command; bad input."""

import csv
import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

optuna = pytest.importorskip("optuna")  # the optional extra; CI installs it (.ci/run)

from sklearn.datasets import load_iris  # noqa: E402
from sklearn.preprocessing import StandardScaler  # noqa: E402

from qdensity.cli import main  # noqa: E402
from qdensity.learning.estimators import QNNClassifier  # noqa: E402
from qdensity.learning.sweep import (  # noqa: E402
    MEMORY,
    PAPER_SPACE,
    export_trials,
    open_study,
    run_sweep,
    run_trials,
    startup_trials,
)

ROOT = Path(__file__).resolve().parents[2]
SMALL = {"learning_rate": ("log", 1e-3, 1e-1), "optimizer": ("categorical", ["adam", "sgd"])}


def _data():
    X, y = load_iris(return_X_y=True)
    return StandardScaler().fit_transform(X), y


WORKER = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from sklearn.datasets import load_iris
    from sklearn.preprocessing import StandardScaler
    from qdensity.learning.estimators import QNNClassifier
    from qdensity.learning import sweep
    from qdensity.learning.sweep import run_sweep

    storage, me, other, n = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4])
    X, y = load_iris(return_X_y=True)
    X = StandardScaler().fit_transform(X)
    fit = sweep._evaluate

    def evaluate(*args):
        # the first fit of each worker waits for the other's first (a fit takes ~40 ms: one
        # worker could otherwise finish all n before the other opens the study)
        Path(f"{me}.fit").touch()
        t0 = time.monotonic()
        while not Path(f"{other}.fit").exists() and time.monotonic() - t0 < 120:
            time.sleep(0.01)
        return fit(*args)

    sweep._evaluate = evaluate
    me.touch()
    while not other.exists():  # start together
        time.sleep(0.01)
    run_sweep(X, y, QNNClassifier(epochs=3, verbose=False), n_trials=n, storage=storage,
              space={"learning_rate": ("log", 1e-3, 1e-1)}, verbose=False, study_name="s")
""")


def test_two_workers_share_one_fresh_sqlite_study(tmp_path):
    storage = f"sqlite:///{tmp_path / 'study.db'}"  # fresh: the two race for the schema
    n = 8
    # keep whatever else is on the path (packages installed with --target, say)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}
    a, b = tmp_path / "a", tmp_path / "b"
    procs = [subprocess.Popen([sys.executable, "-c", WORKER, storage, str(me), str(other),
                               str(n)], env=env, stderr=subprocess.PIPE, text=True)
             for me, other in ((a, b), (b, a))]
    for p in procs:
        _, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
    study = open_study("s", storage)
    complete = [t for t in study.trials if t.state.name == "COMPLETE"]
    skipped = [t for t in study.trials if "skipped" in t.user_attrs]
    assert sorted(t.number for t in complete) == list(range(n))  # none lost, none twice
    assert all(t.state.name == "PRUNED" and t.number >= n and not t.params for t in skipped)
    assert len(study.trials) == n + len(skipped) and len(skipped) <= 2
    assert {t.user_attrs["worker"] for t in complete} == {p.pid for p in procs}
    assert all(0 <= t.value <= 1 for t in complete)


class _Interrupt:
    """A per-step callback that stops the process like Ctrl-C during the third trial (the count
    is a class attribute: ``clone`` gives every trial a copy of the callback)."""

    fits = 0

    def __call__(self, est, step):
        if step == 0:
            type(self).fits += 1
        if type(self).fits == 3 and step == 2:
            raise KeyboardInterrupt


def test_interrupted_sweep_keeps_finished_trials_and_resumes(tmp_path):
    X, y = _data()
    storage = f"sqlite:///{tmp_path / 's.db'}"
    _Interrupt.fits = 0
    est = QNNClassifier(epochs=2, verbose=False, callback=_Interrupt())
    with pytest.raises(KeyboardInterrupt):
        run_sweep(X, y, est, n_trials=5, storage=storage, space=SMALL, verbose=False)
    name = optuna.get_all_study_names(storage)[0]  # the default name: from the settings
    assert name.startswith("sweep-")
    study = open_study(name, storage)
    assert [t.state.name for t in study.trials] == ["COMPLETE", "COMPLETE", "FAIL"]
    run_sweep(X, y, QNNClassifier(epochs=2, verbose=False), n_trials=5, storage=storage,
              space=SMALL, verbose=False)
    study = open_study(name, storage)
    assert [t.state.name for t in study.trials].count("COMPLETE") == 5
    assert len(study.trials) == 6


def test_export_json_and_csv(tmp_path):
    X, y = _data()
    study = run_sweep(X, y, QNNClassifier(epochs=1, verbose=False), n_trials=3,
                      storage=f"sqlite:///{tmp_path / 'e.db'}", space=PAPER_SPACE,
                      sampler_seed=1, verbose=False)
    doc = json.loads(export_trials(study, tmp_path / "t.json").read_text())
    with (tmp_path / "t.csv").open() if export_trials(study, tmp_path / "t.csv") else None as fh:
        rows = list(csv.DictReader(fh))
    assert doc["study"] == study.study_name and len(doc["trials"]) == len(rows) == 3
    for t, j, c in zip(study.trials, doc["trials"], rows, strict=True):
        assert j["value"] == t.value and float(c["value"]) == pytest.approx(t.value)
        assert j["param_optimizer"] == c["param_optimizer"] == t.params["optimizer"]
        assert int(c["param_batch_size"]) == t.params["batch_size"]
        assert 32 <= t.params["batch_size"] <= 256 and t.params["batch_size"] % 16 == 0
        assert 1e-4 <= t.params["learning_rate"] <= 1e-2
    with pytest.raises(ValueError, match="path must end in .json or .csv"):
        export_trials(study, tmp_path / "t.txt")


def test_sweep_command(tmp_path, capsys):
    storage = f"sqlite:///{tmp_path / 'cli.db'}"
    out = tmp_path / "trials.csv"
    assert main(["sweep", "--dataset", "iris", "--num-qubits", "3", "--epochs", "1",
                 "--n-trials", "2", "--storage", storage, "--export", str(out),
                 "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] == 2 and len(out.read_text().splitlines()) == 3
    assert main(["sweep", "--storage", "sqlite:////no/such/dir/x.db", "--n-trials", "1"]) == 2
    assert "storage" in capsys.readouterr().err
    assert main(["sweep", "--dataset", "cifar", "--storage", storage]) == 2
    assert "unknown dataset 'cifar'" in capsys.readouterr().err


def test_a_study_is_identified_by_its_settings(tmp_path, capsys):
    """Issue 27: ``--dataset wine`` where the default storage holds an iris study is another
    study; a named study made with other settings is a clear error."""
    storage = f"sqlite:///{tmp_path / 'qdensity-sweep.db'}"
    common = ["--num-qubits", "3", "--epochs", "1", "--n-trials", "1", "--storage", storage,
              "--quiet"]
    assert main(["sweep", "--dataset", "iris", *common]) == 0
    iris = json.loads(capsys.readouterr().out)
    assert main(["sweep", "--dataset", "wine", *common]) == 0
    wine = json.loads(capsys.readouterr().out)
    assert iris["study"].startswith("iris-") and wine["study"].startswith("wine-")
    assert wine["complete"] == 1 and wine["best_params"] != iris["best_params"]
    assert sorted(optuna.get_all_study_names(storage)) == sorted([iris["study"],
                                                                  wine["study"]])
    assert main(["sweep", "--dataset", "wine", "--study", iris["study"], *common]) == 2
    err = capsys.readouterr().err
    assert f"study {iris['study']!r} in this storage was made with other settings" in err
    assert "data:" in err  # the first difference: the data's fingerprint
    assert main(["sweep", "--dataset", "iris", "--epochs", "2", "--study", iris["study"],
                 *common[2:]]) == 2
    assert "params:" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--samples", "-5"], "argument --samples: must be in [2, "),
    (["--samples", "0"], "argument --samples: must be in [2, "),
    (["--dataset", "iris", "--samples", "151"], "--samples 151 is more than the 150 rows"),
    (["--n-trials", "0"], "--n-trials: must be in [1, "),
    (["--epochs", "-1"], "--epochs: must be in [1, "),
    (["--grace-period", "1"], "--grace-period: must be in [3, "),
    (["--cluster", "lokal:2"], "unknown cluster address 'lokal:2'; allowed: 'local'"),
])
def test_bad_sweep_command_input(tmp_path, capsys, argv, message):
    storage = f"sqlite:///{tmp_path / 'bad.db'}"
    try:
        code = main(["sweep", "--storage", storage, "--quiet", *argv])
    except SystemExit as exc:  # a usage error, already printed on one line
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_tpe_is_tpe_after_a_short_random_start():
    assert [startup_trials(n) for n in (1, 2, 8, 32, 100)] == [1, 1, 2, 8, 10]
    study = open_study("tpe", MEMORY, n_trials=8, seed=0)
    assert study.sampler.__class__.__name__ == "TPESampler"
    assert study.sampler._n_startup_trials == 2 < 8  # optuna's default 10 is random search
    # the oracle: TPE concentrates on the optimum of a quadratic after the random start,
    # where the same number of random draws (the same sampler's first draws) spreads out
    values = []

    def evaluate(trial):
        x = trial.suggest_float("x", -10.0, 10.0)
        values.append(x)
        return -(x - 3.0) ** 2

    assert run_trials(study, evaluate, 40) == 40
    late = np.abs(np.array(values[20:]) - 3.0)
    assert np.median(late) < 3.0  # uniform on [-10, 10] (random search): median distance 5


def test_bad_sweep_input(tmp_path):
    X, y = _data()
    storage = f"sqlite:///{tmp_path / 'b.db'}"
    with pytest.raises(ValueError, match="storage must be an optuna storage URL"):
        run_sweep(X, y, storage="study.db")
    with pytest.raises(ValueError, match="grace_period must be an int of at least 3"):
        open_study("s", storage, grace_period=1)
    with pytest.raises(ImportError, match="needs a database driver .*install a MySQL driver"):
        open_study("s", "mysql://u@127.0.0.1:1/db")
    if importlib.util.find_spec("psycopg") is None:  # SQLAlchemy 2.1: postgresql:// is psycopg 3
        with pytest.raises(ImportError, match=r"psycopg 3.*postgresql\+psycopg2://"):
            open_study("s", "postgresql://u@127.0.0.1:1/db")
    if importlib.util.find_spec("psycopg2") is None:
        with pytest.raises(ImportError, match="psycopg2-binary"):
            open_study("s", "postgresql+psycopg2://u@127.0.0.1:1/db")
    with pytest.raises(ValueError, match="storage 'nosuchdb://x' cannot be opened"):
        open_study("s", "nosuchdb://x")
    with pytest.raises(ValueError, match="'learnig_rate', which is not a hyperparameter"):
        run_sweep(X, y, space={"learnig_rate": ("log", 1e-3, 1e-1)}, storage=storage)
    with pytest.raises(ValueError, match=r"space\['epochs'\] must be"):
        run_sweep(X, y, space={"epochs": ("uniform", 1, 3)}, storage=storage)
    with pytest.raises(ValueError, match="n_trials"):
        run_sweep(X, y, n_trials=0, storage=storage)
    with pytest.raises(ValueError, match=r"seed must be an int >= 0.*got -1"):
        run_sweep(X, y, seed=-1, storage=storage)
    with pytest.raises(TypeError, match=r"seed must be an int >= 0.*got float 1.5"):
        run_sweep(X, y, seed=1.5, storage=storage)
    with pytest.raises(TypeError, match=r"^seed must be an int >= 0, got NoneType"):
        run_sweep(X, y, seed=None, storage=storage)
    with pytest.raises(ValueError, match=r"sampler_seed must be an int >= 0.*got -2"):
        run_sweep(X, y, sampler_seed=-2, storage=storage)
    assert np.isfinite(X).all()
