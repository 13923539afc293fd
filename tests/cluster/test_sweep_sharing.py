"""Sweeps that many workers share, on SQLite and on a real PostgreSQL server: workers started
together on a fresh storage all finish with exactly ``n`` COMPLETE trials; a ``qdensity sweep``
worker SIGKILLed mid-trial has its trial run again (same parameters) by the other after the
grace period; ``qdensity sweep --cluster`` runs the trials on Dask workers."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

optuna = pytest.importorskip("optuna")  # the sweep extra; CI installs it (.ci/run)

from qdensity.cli import main  # noqa: E402
from qdensity.learning._study import retried_from  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}


_STORAGES: dict[str, object] = {}


def _trials(storage: str, name: str) -> list:
    """The study's trials, read through one storage per URL whose engine keeps no connection
    between reads (NullPool): the tests poll this many times a second, and a pooled engine per
    call (``load_study(storage=url)``) left its connections open until garbage collection,
    which exhausted the PostgreSQL server's ``max_connections`` ("too many clients already");
    building a storage per call also re-ran its schema checks against the workers' writes."""
    from sqlalchemy.pool import NullPool

    rdb = _STORAGES.get(storage)
    if rdb is None:
        rdb = _STORAGES[storage] = optuna.storages.RDBStorage(
            storage, engine_kwargs={"poolclass": NullPool})
    try:
        return optuna.load_study(study_name=name, storage=rdb).get_trials(deepcopy=False)
    except KeyError:  # not created yet
        return []


def test_eight_workers_started_together_on_a_fresh_storage_all_finish(fresh_storage,
                                                                      tmp_path):
    """(Two workers on a fresh SQLite file: tests/learning/test_sweep.py.)"""
    n, workers = 12, 8
    start = tmp_path / "start"
    start.mkdir()
    procs = [subprocess.Popen([sys.executable, str(HERE / "_race_worker.py"), fresh_storage,
                               str(n), str(start), f"w{i}", str(workers)], env=ENV,
                              stderr=subprocess.PIPE, text=True) for i in range(workers)]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err  # no "table studies already exists", no UNIQUE error
    trials = _trials(fresh_storage, "race")
    complete = [t for t in trials if t.state.name == "COMPLETE"]
    assert len(complete) == n
    assert all(t.state.name in ("COMPLETE", "PRUNED") for t in trials)
    assert all("skipped" in t.user_attrs for t in trials if t.state.name == "PRUNED")


def _sweep_worker(storage: str, n: int, stall: Path | None = None) -> subprocess.Popen:
    """``qdensity sweep`` on ``storage``; with ``stall``, one whose first fit never ends (it
    creates the file ``stall`` when it is mid-trial: tests/cluster/_stalling_worker.py)."""
    argv = ["sweep", "--dataset", "iris", "--num-qubits", "3", "--epochs", "8",
            "--n-trials", str(n), "--storage", storage, "--study", "shared",
            "--grace-period", "3", "--quiet"]
    head = ["-c", "import sys; from qdensity.cli import main; sys.exit(main(sys.argv[1:]))"] \
        if stall is None else [str(HERE / "_stalling_worker.py"), str(stall)]
    return subprocess.Popen([sys.executable, *head, *argv], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _running(storage: str, pid: int) -> list:
    return [t for t in _trials(storage, "shared")
            if t.state.name == "RUNNING" and t.user_attrs.get("worker") == pid]


def test_a_killed_workers_trial_is_run_again_and_the_study_completes(fresh_storage, tmp_path):
    """Worker A stalls in its first fit (a real trial takes ~40 ms, too short to catch by
    polling); B starts, A is SIGKILLed mid-trial, and B alone brings the study to ``n``."""
    n, flag = 4, tmp_path / "a-mid-trial"
    a = _sweep_worker(fresh_storage, n, stall=flag)
    b = None
    try:
        t0 = time.monotonic()
        while not flag.exists():
            assert a.poll() is None, a.communicate()[1]  # A died before its trial
            assert time.monotonic() - t0 < 180, "worker A never started a trial"
            time.sleep(0.1)
        killed = _running(fresh_storage, a.pid)  # A is alive: its trial's heartbeat runs
        assert len(killed) == 1
        b = _sweep_worker(fresh_storage, n)
        os.kill(a.pid, signal.SIGKILL)  # mid-trial: no chance to mark it FAIL
        a.wait(timeout=30)
        out, err = b.communicate(timeout=300)
    finally:
        a.kill()
        if b is not None:
            b.kill()
    assert b.returncode == 0, err
    assert json.loads(out)["complete"] == n
    trials = {t.number: t for t in _trials(fresh_storage, "shared")}
    complete = [t for t in trials.values() if t.state.name == "COMPLETE"]
    assert len(complete) == n  # exactly n, the dead trial not among them
    dead = trials[killed[0].number]
    assert dead.state.name == "FAIL"
    retries = [t for t in complete if retried_from(t) == dead.number]
    assert len(retries) == 1 and retries[0].params == dead.params
    assert retries[0].user_attrs["worker"] == b.pid


def test_sweep_command_runs_trials_on_dask_workers(client, tmp_path, capsys):
    storage = f"sqlite:///{tmp_path / 'dask.db'}"
    address = client.scheduler.address
    assert main(["sweep", "--dataset", "iris", "--num-qubits", "3", "--epochs", "1",
                 "--n-trials", "3", "--storage", storage, "--cluster", address,
                 "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["complete"] == 3
    trials = _trials(storage, summary["study"])
    complete = [t for t in trials if t.state.name == "COMPLETE"]
    assert len(complete) == 3
    workers = set(client.scheduler_info()["workers"])
    assert {t.user_attrs["dask_worker"] for t in complete} <= workers
