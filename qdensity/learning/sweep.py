"""Hyperparameter sweeps with optuna (optional extra: ``pip install "qdensity[sweep]"``).

The paper tunes every OrthoQNN model with optuna, 32 trials per model (Supp.
"Hyperparameters"): ``batch_size in {32, 48, ..., 256}``, ``learning_rate`` log-uniform in
``[1e-4, 1e-2]``, ``optimiser in {Adam, SGD, RMSProp}``, ``regularisation in {l2, None}``
(:data:`PAPER_SPACE`; "l2" is ``l2=1e-4`` here). :func:`run_sweep` runs such a search over any
scikit-learn estimator (a :class:`~qdensity.learning.estimators.QNNClassifier` by default) and
a dataset, scored on a held-out split.

Trials live in an optuna storage: an SQLite file by default, or any optuna storage URL
(``postgresql://...``, ``mysql://...``) so that many worker processes on many machines share
one study -- start the same command on each machine. Every finished trial is committed to the
storage at once, so an interrupted sweep loses none (the interrupted trial is marked FAIL),
and rerunning the command resumes the study until it has ``n_trials`` finished or running
trials. Workers never run more than ``n_trials`` between them: a worker claims a trial number
from the storage (atomic) before running it, and one whose trial falls past the end, among
the finished and running ones, records it as a skipped trial (state FAIL, user attribute
``skipped``) and stops. :func:`export_trials` writes the trials as JSON or CSV.
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from sklearn.base import clone, is_classifier
from sklearn.model_selection import train_test_split

from qdensity.progress import progress_bar
from qdensity.validation import check_positive_int

__all__ = ["PAPER_SPACE", "DEFAULT_STORAGE", "run_sweep", "open_study", "export_trials",
           "trial_rows"]

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


def _optuna():
    try:
        import optuna
    except ImportError as exc:  # pragma: no cover - exercised only without the extra
        raise ImportError('sweeps need optuna: pip install "qdensity[sweep]"') from exc
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def open_study(study_name: str = "qdensity", storage: str | None = None, *,
               direction: str = "maximize", seed: int | None = None):
    """Create or load (``load_if_exists``) the study ``study_name`` in ``storage``.

    Parameters
    ----------
    study_name : str
    storage : str, optional
        Any optuna storage URL (default :data:`DEFAULT_STORAGE`, an SQLite file in the
        working directory).
    direction : {"maximize", "minimize"}
    seed : int, optional
        Seed of the TPE sampler (None: fresh randomness, right for several workers).

    Raises
    ------
    ValueError
        When the storage cannot be opened (bad URL, missing directory, unknown database).
    """
    optuna = _optuna()
    storage = DEFAULT_STORAGE if storage is None else storage
    if not isinstance(storage, str) or "://" not in storage:
        raise ValueError(f"storage must be an optuna storage URL such as "
                         f"'sqlite:///sweep.db' or 'postgresql://user@host/db', got {storage!r}")
    if direction not in ("maximize", "minimize"):
        raise ValueError(f"direction must be 'maximize' or 'minimize', got {direction!r}")
    try:
        rdb = optuna.storages.RDBStorage(storage, heartbeat_interval=None,
                                         engine_kwargs={"connect_args": {"timeout": 60}}
                                         if storage.startswith("sqlite") else None)
    except Exception as exc:  # noqa: BLE001 - SQLAlchemy raises many kinds
        raise ValueError(f"storage {storage!r} cannot be opened: {type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else ''}") from exc
    sampler = optuna.samplers.TPESampler(seed=seed)
    return optuna.create_study(study_name=study_name, storage=rdb, direction=direction,
                               sampler=sampler, load_if_exists=True)


def _check_space(space: Mapping, estimator) -> None:
    known = estimator.get_params()
    for name, spec in space.items():
        if name not in known:
            raise ValueError(f"space names {name!r}, which is not a hyperparameter of "
                             f"{type(estimator).__name__} (allowed: {sorted(known)})")
        if not isinstance(spec, (tuple, list)) or not spec or spec[0] not in (
                "int", "log", "float", "categorical"):
            raise ValueError(f"space[{name!r}] must be ('int', lo, hi[, step]), ('log', lo, "
                             f"hi), ('float', lo, hi) or ('categorical', choices), got {spec!r}")


def _suggest(trial, space: Mapping) -> dict:
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


def run_sweep(X, y, estimator=None, *, n_trials: int = 32, space: Mapping | None = None,
              storage: str | None = None, study_name: str = "qdensity",
              validation_size: float = 0.25, seed: int = 0, sampler_seed: int | None = None,
              verbose: bool = True, stop_after: int | None = None):
    """Run (this worker's share of) a sweep until the study has ``n_trials`` trials.

    Parameters
    ----------
    X : array_like, shape (N, d)
    y : array_like, shape (N,)
    estimator : scikit-learn estimator, optional
        Cloned for every trial (default ``QNNClassifier(verbose=False)``).
    n_trials : int
        Trials of the whole study, over all workers (the paper: 32).
    space : dict, optional
        Default :data:`PAPER_SPACE`.
    storage : str, optional
        optuna storage URL (default :data:`DEFAULT_STORAGE`).
    study_name : str
    validation_size : float
        Held-out fraction (stratified for classifiers), the same split in every trial.
    seed : int
        Seed of the train/validation split (the same on every worker).
    sampler_seed : int, optional
        Seed of optuna's TPE sampler: reproducible suggestions for one worker; leave None
        when several workers share a study, or give each its own.
    verbose : bool
        A tqdm bar on a terminal.
    stop_after : int, optional
        Run at most this many trials in this call.

    Returns
    -------
    optuna.Study
        ``study.trials`` holds every trial; user attributes ``seconds`` and ``shots``.
    """
    _optuna()
    from optuna.trial import TrialState

    if estimator is None:
        from qdensity.learning.estimators import QNNClassifier

        estimator = QNNClassifier(verbose=False)
    n_trials = check_positive_int(n_trials, "n_trials")
    space = PAPER_SPACE if space is None else space
    _check_space(space, estimator)
    if not (isinstance(validation_size, float) and 0 < validation_size < 1):
        raise ValueError(f"validation_size must be a float in (0, 1), got {validation_size!r}")
    X = np.asarray(X)
    y = np.asarray(y)
    classify = is_classifier(estimator)
    X_tr, X_va, y_tr, y_va = train_test_split(X, y, test_size=validation_size, random_state=seed,
                                              stratify=y if classify else None)
    study = open_study(study_name, storage, seed=sampler_seed)
    done = 0
    with progress_bar(n_trials, desc=f"sweep {study_name}", verbose=verbose,
                      unit="trial") as bar:
        bar.update(min(len(_counting(study, TrialState)), n_trials))
        while stop_after is None or done < stop_after:
            if len(_counting(study, TrialState)) >= n_trials:
                break
            trial = study.ask()
            if _counting(study, TrialState).index(trial.number) >= n_trials:
                # other workers claimed the last trials between our count and our ask
                trial.set_user_attr("skipped", f"the study already has {n_trials} trials")
                study.tell(trial, state=TrialState.FAIL)
                break
            try:
                value, attrs = _evaluate(estimator, _suggest(trial, space), X_tr, y_tr, X_va,
                                         y_va)
            except BaseException:
                study.tell(trial, state=TrialState.FAIL)
                raise
            for key, val in attrs.items():
                trial.set_user_attr(key, val)
            trial.set_user_attr("worker", os.getpid())
            if math.isfinite(value):
                study.tell(trial, value)
            else:
                study.tell(trial, state=TrialState.FAIL)
            done += 1
            bar.update(1)
            best = study.best_value if any(t.state == TrialState.COMPLETE
                                           for t in study.trials) else float("nan")
            bar.set_postfix(best=f"{best:.3f}", shots=attrs["shots"])
    return study


def _counting(study, TrialState) -> list[int]:
    """Numbers of the trials that count towards ``n_trials`` (finished or running), sorted."""
    states = (TrialState.COMPLETE, TrialState.RUNNING)
    return sorted(t.number for t in study.get_trials(deepcopy=False, states=states))


def _evaluate(estimator, params, X_tr, y_tr, X_va, y_va) -> tuple[float, dict]:
    est = clone(estimator).set_params(**params)
    t0 = time.perf_counter()
    est.fit(X_tr, y_tr)
    score = float(est.score(X_va, y_va))
    layer = getattr(est, "layer_", None)
    return score, {"seconds": time.perf_counter() - t0,
                   "shots": int(getattr(layer, "shots_spent", 0))}


def trial_rows(study) -> list[dict]:
    """One flat dict per trial: number, state, value, params, user attributes, seconds."""
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
        path.write_text(json.dumps(doc, indent=1, default=str))
    else:
        keys = list(dict.fromkeys(k for r in rows for k in r))
        with path.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=keys)
            writer.writeheader()
            writer.writerows(rows)
    return path
