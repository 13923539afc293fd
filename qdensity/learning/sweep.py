"""Hyperparameter sweeps with optuna (optional extra: ``pip install -e ".[sweep]"``).

The paper tunes every OrthoQNN model with optuna, 32 trials per model (Supp.
"Hyperparameters"): ``batch_size in {32, 48, ..., 256}``, ``learning_rate`` log-uniform in
``[1e-4, 1e-2]``, ``optimiser in {Adam, SGD, RMSProp}``, ``regularisation in {l2, None}``
(:data:`PAPER_SPACE`; "l2" is ``l2=1e-4`` here). :func:`run_sweep` runs such a search over any
scikit-learn estimator (a :class:`~qdensity.learning.estimators.QNNClassifier` by default) and
a dataset, scored on a held-out split; :func:`run_trials` is the loop itself, for any
objective (the ``moe`` experiment's sweeps use it).

Trials live in an optuna storage: an SQLite file by default, any optuna storage URL
(``postgresql+psycopg2://...`` with the extra's driver, ``mysql+pymysql://...``), or an optuna
storage object (``RDBStorage``, ``JournalStorage``, ``InMemoryStorage``), so that many
worker processes on many machines share one study -- start the same command on each machine, or
give ``cluster`` (Dask) and the trials run on its workers. The study ends with exactly
``n_trials`` COMPLETE trials:

* the schema is created once, however many workers start together on a fresh storage (a file
  lock for SQLite, retries for a database server);
* a worker claims a trial number from the storage (atomic) before running it; one whose trial
  falls past the end, among the finished and running ones, records it as a skipped trial
  (state PRUNED, user attribute ``skipped``, no parameters) and waits while others run the
  last ones, in case one of them dies;
* every running trial sends a heartbeat (every third of ``grace_period``); a trial silent for
  ``grace_period`` seconds (its worker killed) is marked FAIL and run again with the same
  parameters (optuna's ``RetryFailedTrialCallback``, up to three times) by a live worker;
* an interrupted worker (Ctrl-C) marks its trial FAIL; a trial whose score is not finite is
  FAIL; neither counts, so another trial takes its place. Rerunning the command resumes.

A study is tied to its settings (estimator, its hyperparameters, search space, a fingerprint
of the data, validation split): its default name is derived from them, and opening a study of
that name made with other settings is an error naming the first difference. The sampler is
TPE with ``startup_trials(n_trials)`` random trials first (a quarter of ``n_trials``, 1 to 10;
optuna's default of 10 would make a study of 8 trials random search). :func:`export_trials`
writes the trials as JSON or CSV.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from sklearn.base import clone, is_classifier
from sklearn.model_selection import train_test_split

from qdensity.cluster import IN_PROCESS, worker_name
from qdensity.io import atomic_write, atomic_write_text
from qdensity.learning._study import (
    DEFAULT_GRACE_PERIOD,
    MEMORY,
    _absolute,
    _check_space,
    _int_seed,
    _optuna,
    in_memory,
    retried_from,
    settings_hash,
    startup_trials,
)
from qdensity.progress import progress_bar
from qdensity.validation import Instance, check_positive_int, validates

if TYPE_CHECKING:
    from optuna import Study

__all__ = ["PAPER_SPACE", "DEFAULT_STORAGE", "DEFAULT_GRACE_PERIOD", "MEMORY", "run_sweep",
           "run_trials", "open_study", "sweep_settings", "suggest_params", "startup_trials",
           "export_trials", "trial_rows", "settings_hash", "retried_from"]

#: The paper's search space: name -> ("int", low, high, step) | ("log", low, high) |
#: ("categorical", choices).
PAPER_SPACE: dict[str, tuple] = {
    "batch_size": ("int", 32, 256, 16),
    "learning_rate": ("log", 1e-4, 1e-2),
    "optimizer": ("categorical", ["adam", "sgd", "rmsprop"]),
    "l2": ("categorical", [0.0, 1e-4]),
}

#: Where trials go when no storage is given.
DEFAULT_STORAGE = "sqlite:///qdensity-sweep.db"

#: What a ``storage`` argument accepts: a URL, or an optuna storage object (loaded lazily:
#: optuna is an optional extra).
STORAGE = Instance((str, "optuna.storages:BaseStorage"),
                   "an optuna storage URL (str) or storage object (optuna.storages.BaseStorage: "
                   "RDBStorage, JournalStorage, InMemoryStorage)", example=MEMORY)

#: Estimator parameters that do not change what a trial measures.
_NOT_SETTINGS = ("verbose", "callback", "callbacks")


@validates(storage=[STORAGE, None])
def open_study(study_name: str = "qdensity", storage=None, *,
               direction: str = "maximize", seed: int | None = None, n_trials: int = 32,
               settings: Mapping | None = None,
               grace_period: int | None = DEFAULT_GRACE_PERIOD) -> Study:
    """Create or load (``load_if_exists``) the study ``study_name`` in ``storage``.

    Parameters
    ----------
    study_name : str
    storage : str or optuna.storages.BaseStorage, optional
        Any optuna storage URL (default :data:`DEFAULT_STORAGE`, an SQLite file in the
        working directory), :data:`MEMORY` for a study in this process only, or an optuna
        storage object (``RDBStorage``, ``JournalStorage``, ``InMemoryStorage``), used as
        it is: its own heartbeat settings hold and ``grace_period`` is not applied to it.
    direction : {"maximize", "minimize"}
    seed : int, optional
        Seed of the TPE sampler (None: fresh randomness, right for several workers).
    n_trials : int
        Trials the study will have: sets the sampler's random start (:func:`startup_trials`).
    settings : mapping, optional
        What the study measures; stored with a new study, compared with an existing one's.
    grace_period : int or None
        Seconds without a heartbeat after which a RUNNING trial is dead and retried (at least
        3; heartbeats every third of it). None: no heartbeats. Applies to storages opened
        from a URL; a storage object keeps its own.

    Returns
    -------
    optuna.Study

    Raises
    ------
    ValueError
        When the storage cannot be opened (bad URL, missing directory, unknown database), or
        the study was made with other ``settings`` (the message names the first difference).
    ImportError
        When the storage's database driver is missing (the message says what to install).

    Examples
    --------
    >>> from qdensity.learning.sweep import MEMORY, open_study
    >>> study = open_study("demo", MEMORY, direction="minimize", seed=0)
    >>> study.study_name, study.direction.name, len(study.trials)
    ('demo', 'MINIMIZE', 0)
    """
    from qdensity.learning._study import open_study as _open

    return _open(study_name, DEFAULT_STORAGE if storage is None else storage,
                 direction=direction, seed=seed, n_trials=n_trials, settings=settings,
                 grace_period=grace_period)


def suggest_params(trial, space: Mapping) -> dict:
    """The trial's value of every hyperparameter of ``space`` (see :data:`PAPER_SPACE`).

    Examples
    --------
    >>> from optuna.trial import FixedTrial
    >>> from qdensity.learning.sweep import suggest_params
    >>> suggest_params(FixedTrial({"lr": 0.01, "l2": 0.0}), {"lr": ("log", 1e-4, 1e-1),
    ...                                                      "l2": ("categorical", [0.0, 1e-4])})
    {'lr': 0.01, 'l2': 0.0}
    """
    params = {}
    for name, spec in space.items():
        kind = spec[0]
        if kind == "int":
            params[name] = trial.suggest_int(name, spec[1], spec[2],
                                             step=spec[3] if len(spec) > 3 else 1)
        elif kind == "log":
            params[name] = trial.suggest_float(name, spec[1], spec[2], log=True)
        elif kind == "float":
            params[name] = trial.suggest_float(name, spec[1], spec[2])
        else:
            params[name] = trial.suggest_categorical(name, list(spec[1]))
    return params


def sweep_settings(X, y, estimator, space: Mapping, validation_size: float, seed: int) -> dict:
    """What a sweep measures, for naming and checking its study: the estimator's class and
    plain hyperparameters, the space, a SHA-256 fingerprint of ``X`` and ``y`` (shapes, dtypes
    and bytes), the validation split.

    Examples
    --------
    >>> from sklearn.linear_model import LogisticRegression
    >>> from qdensity.learning.sweep import sweep_settings
    >>> s = sweep_settings(np.zeros((4, 2)), np.arange(4) % 2, LogisticRegression(), {}, 0.25, 0)
    >>> s["estimator"], len(s["data"]), s["validation_size"]  # data: a 16-digit fingerprint
    ('LogisticRegression', 16, 0.25)
    """
    digest = hashlib.sha256()
    for a in (np.ascontiguousarray(X), np.ascontiguousarray(y)):
        digest.update(f"{a.shape}{a.dtype}".encode())
        digest.update(a.tobytes())
    params = {k: v for k, v in sorted(estimator.get_params(deep=False).items())
              if k not in _NOT_SETTINGS}
    return {"estimator": type(estimator).__name__, "params": params,
            "space": {k: list(v) for k, v in space.items()}, "data": digest.hexdigest()[:16],
            "validation_size": validation_size, "split_seed": seed}


def run_trials(study, evaluate, n_trials: int, *, stop_after: int | None = None,
               verbose: bool = False) -> int:
    """Run trials of ``study`` until it has ``n_trials`` COMPLETE trials, shared with any
    other workers of the same study (see the module docstring).

    Parameters
    ----------
    study : optuna.Study
        From :func:`open_study`.
    evaluate : callable
        ``evaluate(trial) -> float``: suggests the trial's parameters, scores them, may set
        user attributes. A non-finite score marks the trial FAIL; an exception marks it FAIL
        and is raised.
    n_trials : int
        COMPLETE trials the study ends with.
    stop_after : int, optional
        Complete at most this many trials in this call.
    verbose : bool
        A tqdm bar on a terminal.

    Returns
    -------
    int
        Trials this call completed. It also stops after more than ``n_trials`` of its own
        trials failed (an objective that always fails).

    Examples
    --------
    >>> from qdensity.learning.sweep import MEMORY, open_study, run_trials
    >>> study = open_study("parabola", MEMORY, direction="minimize", seed=0, n_trials=4)
    >>> run_trials(study, lambda trial: (trial.suggest_float("x", -1, 1) - 0.5) ** 2, 4)
    4
    >>> run_trials(study, lambda trial: 0.0, 4)  # the study is complete: nothing to run
    0
    """
    optuna = _optuna()
    from optuna.exceptions import ExperimentalWarning
    from optuna.trial import TrialState

    n_trials = check_positive_int(n_trials, "n_trials")
    storage = study._storage  # optuna gives no public handle on a study's storage
    beat = storage.get_heartbeat_interval() if hasattr(storage, "get_heartbeat_interval") \
        else None
    poll = None if beat is None else min(float(beat), 1.0)  # seconds between looks
    last: dict = {}

    def objective(trial):
        last["number"] = trial.number
        counted = sorted(t.number for t in study.get_trials(
            deepcopy=False, states=(TrialState.COMPLETE, TrialState.RUNNING)))
        if trial.number not in counted[:n_trials]:
            # other workers claimed the last trials between our count and our ask
            last["number"] = None
            trial.set_user_attr("skipped", f"the study already has {n_trials} trials")
            raise optuna.TrialPruned
        return evaluate(trial)

    completed = failed = shown = 0
    with progress_bar(n_trials, desc=f"sweep {study.study_name}", verbose=verbose,
                      unit="trial") as bar:
        while stop_after is None or completed < stop_after:
            if poll is not None:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ExperimentalWarning)
                    optuna.storages.fail_stale_trials(study)  # dead workers' trials: retried
            trials = study.get_trials(deepcopy=False)
            count = {s: sum(t.state == s for t in trials) for s in TrialState}
            done = min(count[TrialState.COMPLETE], n_trials)
            bar.update(done - shown)
            shown = done
            if done >= n_trials or failed > n_trials:
                break
            if (count[TrialState.COMPLETE] + count[TrialState.RUNNING] >= n_trials
                    and not count[TrialState.WAITING]):
                if poll is None:  # no heartbeats: a dead worker's trial cannot be told
                    break
                time.sleep(poll)  # the last trials run elsewhere: wait in case one dies
                continue
            study.optimize(objective, n_trials=1, gc_after_trial=False)
            if last.get("number") is None:
                continue
            states = {t.number: t.state for t in study.get_trials(deepcopy=False)}
            if states.get(last["number"]) == TrialState.COMPLETE:
                completed += 1
            else:
                failed += 1
    return completed


@validates(storage=[STORAGE, None])
def run_sweep(X, y, estimator=None, *, n_trials: int = 32, space: Mapping | None = None,
              storage=None, study_name: str | None = None,
              validation_size: float = 0.25, seed: int = 0, sampler_seed: int | None = None,
              verbose: bool = True, stop_after: int | None = None,
              grace_period: int | None = DEFAULT_GRACE_PERIOD, cluster=None) -> Study:
    """Run (this worker's share of) a sweep until the study has ``n_trials`` COMPLETE trials.

    Parameters
    ----------
    X : array_like, shape (N, d)
    y : array_like, shape (N,)
    estimator : scikit-learn estimator, optional
        Cloned for every trial (default ``QNNClassifier(verbose=False)``).
    n_trials : int
        COMPLETE trials of the whole study, over all workers (the paper: 32).
    space : dict, optional
        Default :data:`PAPER_SPACE`.
    storage : str or optuna.storages.BaseStorage, optional
        optuna storage URL (default :data:`DEFAULT_STORAGE`; a relative SQLite path is read
        from the working directory) or storage object (``RDBStorage``, ``JournalStorage``,
        ``InMemoryStorage``; see :func:`open_study`).
    study_name : str, optional
        Default ``"sweep-<hash>"`` of the settings (:func:`sweep_settings`): other data, another
        estimator or space is another study. A named study made with other settings is an
        error.
    validation_size : float
        Held-out fraction (stratified for classifiers), the same split in every trial.
    seed : int
        Seed of the train/validation split (the same on every worker).
    sampler_seed : int, optional
        Seed of optuna's TPE sampler: reproducible suggestions for one worker; leave None
        when several workers share a study, or give each its own (on a ``cluster``, task ``i``
        gets ``sampler_seed + i``).
    verbose : bool
        A tqdm bar on a terminal.
    stop_after : int, optional
        Complete at most this many trials in this call.
    grace_period : int or None
        Seconds without a heartbeat after which a trial counts as dead (its worker killed)
        and is run again (:func:`open_study`).
    cluster : str or distributed.Client, optional
        Run the trials on Dask workers (:mod:`qdensity.cluster`: ``"local:N"``,
        ``"tcp://HOST:PORT"``, a client), one task per missing trial; ``storage`` must then be
        reachable from every worker (a database server, or an SQLite or journal file on a
        shared disk; a storage object travels to the workers pickled), not in memory.

    Returns
    -------
    optuna.Study
        ``study.trials`` holds every trial; user attributes ``seconds``, ``shots`` and
        ``worker`` (process id; ``dask_worker``: the Dask worker's address on a cluster).

    Examples
    --------
    Two trials of a logistic regression's ``C``, in memory:

    >>> from sklearn.linear_model import LogisticRegression
    >>> from qdensity.learning.sweep import MEMORY, run_sweep
    >>> X = np.random.default_rng(0).normal(size=(40, 2)); y = (X[:, 0] > 0).astype(int)
    >>> study = run_sweep(X, y, LogisticRegression(), n_trials=2, space={"C": ("log", 0.01, 10.0)},
    ...                   storage=MEMORY, verbose=False, sampler_seed=0)
    >>> [t.state.name for t in study.trials], sorted(study.trials[0].user_attrs)
    (['COMPLETE', 'COMPLETE'], ['seconds', 'shots', 'worker'])
    """
    _optuna()
    if estimator is None:
        from qdensity.learning.estimators import QNNClassifier

        estimator = QNNClassifier(verbose=False)
    n_trials = check_positive_int(n_trials, "n_trials")
    seed = _int_seed(seed, "seed")
    sampler_seed = None if sampler_seed is None else _int_seed(sampler_seed, "sampler_seed")
    space = PAPER_SPACE if space is None else space
    _check_space(space, estimator)
    if not (isinstance(validation_size, float) and 0 < validation_size < 1):
        raise ValueError(f"validation_size must be a float in (0, 1), got {validation_size!r}")
    X = np.asarray(X)
    y = np.asarray(y)
    settings = sweep_settings(X, y, estimator, space, validation_size, seed)
    if study_name is None:
        from qdensity.learning._study import settings_hash

        study_name = f"sweep-{settings_hash(settings)}"
    storage = _absolute(DEFAULT_STORAGE if storage is None else storage)
    if cluster is not None and in_memory(storage):
        raise ValueError(f"storage {storage!r} keeps its trials in this process's memory, "
                         "which the cluster's workers cannot reach: with cluster give a "
                         "database URL, an SQLite file on a shared disk, or a storage object "
                         "such as RDBStorage or JournalStorage")
    study = open_study(study_name, storage, seed=sampler_seed, n_trials=n_trials,
                       settings=settings, grace_period=grace_period)
    if cluster is not None:
        _on_cluster(cluster, study, (X, y, estimator, n_trials, dict(space), storage,
                                     study_name, validation_size, seed, grace_period),
                    sampler_seed)
        return open_study(study_name, storage, n_trials=n_trials, grace_period=grace_period)
    classify = is_classifier(estimator)
    X_tr, X_va, y_tr, y_va = train_test_split(X, y, test_size=validation_size, random_state=seed,
                                              stratify=y if classify else None)

    def evaluate(trial):
        params = suggest_params(trial, space)
        trial.set_user_attr("worker", os.getpid())  # before the fit: who runs it
        where = worker_name()
        if where != IN_PROCESS:
            trial.set_user_attr("dask_worker", where)
        value, attrs = _evaluate(estimator, params, X_tr, y_tr, X_va, y_va)
        for key, val in attrs.items():
            trial.set_user_attr(key, val)
        return value if math.isfinite(value) else float("nan")

    run_trials(study, evaluate, n_trials, stop_after=stop_after, verbose=verbose)
    return study


def _trial_task(X, y, estimator, n_trials, space, storage, study_name, validation_size, seed,
                grace_period, sampler_seed) -> int:
    """On a Dask worker: complete one trial of the study (or find it complete)."""
    run_sweep(X, y, estimator, n_trials=n_trials, space=space, storage=storage,
              study_name=study_name, validation_size=validation_size, seed=seed,
              sampler_seed=sampler_seed, verbose=False, stop_after=1,
              grace_period=grace_period)
    return 1


def _on_cluster(cluster, study, common: tuple, sampler_seed: int | None) -> None:
    """One Dask task per missing trial."""
    from qdensity.cluster import open_client, run_units

    missing = common[3] - sum(t.state.name == "COMPLETE" for t in study.trials)
    if missing <= 0:
        return
    arguments = [(*common, None if sampler_seed is None else sampler_seed + i)
                 for i in range(missing)]
    with open_client(cluster) as client:
        for _ in run_units(client, _trial_task, arguments):
            pass


def _evaluate(estimator, params, X_tr, y_tr, X_va, y_va) -> tuple[float, dict]:
    est = clone(estimator).set_params(**params)
    t0 = time.perf_counter()
    est.fit(X_tr, y_tr)
    score = float(est.score(X_va, y_va))
    layer = getattr(est, "layer_", None)
    return score, {"seconds": time.perf_counter() - t0,
                   "shots": int(getattr(layer, "shots_spent", 0))}


def trial_rows(study) -> list[dict]:
    """One flat dict per trial: number, state, value, params, user attributes, seconds.

    Examples
    --------
    >>> from qdensity.learning.sweep import MEMORY, open_study, run_trials, trial_rows
    >>> study = open_study("rows", MEMORY, seed=0, n_trials=1)
    >>> _ = run_trials(study, lambda trial: trial.suggest_int("k", 2, 2) / 4, 1)
    >>> trial_rows(study)
    [{'number': 0, 'state': 'COMPLETE', 'value': 0.5, 'param_k': 2}]
    """
    rows = []
    for t in study.trials:
        row = {"number": t.number, "state": t.state.name, "value": t.value}
        row.update({f"param_{k}": v for k, v in t.params.items()})
        row.update({f"attr_{k}": v for k, v in t.user_attrs.items()})
        rows.append(row)
    return rows


def export_trials(study, path: str | os.PathLike) -> Path:
    """Write the study's trials to ``path``: ``.json`` (a list of rows) or ``.csv``.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> from qdensity.learning.sweep import MEMORY, export_trials, open_study, run_trials
    >>> study = open_study("export", MEMORY, seed=0, n_trials=2)
    >>> _ = run_trials(study, lambda trial: trial.suggest_float("x", 0, 1), 2)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = export_trials(study, pathlib.Path(tmp) / "trials.json")
    ...     [row["state"] for row in json.loads(path.read_text())["trials"]]
    ['COMPLETE', 'COMPLETE']
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".csv"):
        raise ValueError(f"path must end in .json or .csv, got {str(path)!r}")
    if not path.parent.is_dir():
        raise ValueError(f"the directory of path {str(path)!r} does not exist")
    rows = trial_rows(study)
    if suffix == ".json":
        doc = {"study": study.study_name, "direction": study.direction.name, "trials": rows}
        atomic_write_text(path, json.dumps(doc, indent=1, default=str))
    else:
        keys = list(dict.fromkeys(k for r in rows for k in r))
        with atomic_write(path, newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=keys)
            writer.writeheader()
            writer.writerows(rows)
    return path
