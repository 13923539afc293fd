"""Opening an optuna study that many workers share: the storage (SQLite, PostgreSQL, MySQL or
in memory, by URL, or any optuna storage object) with heartbeats and retries of dead workers'
trials, a schema created once however many workers start together, a TPE sampler that is
really TPE, and a study tied to its settings."""

from __future__ import annotations

import contextlib
import hashlib
import json
import random
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from qdensity.validation import check_seed

if TYPE_CHECKING:
    from optuna import Study

__all__ = ["MEMORY", "DEFAULT_GRACE_PERIOD", "MAX_RETRY", "retried_from", "startup_trials",
           "settings_hash", "open_study"]

#: The storage "URL" of a study kept in this process's memory (no sharing, no heartbeats).
MEMORY = ":memory:"

#: Seconds after its last heartbeat that a RUNNING trial counts as dead (its worker killed);
#: heartbeats come every third of it.
DEFAULT_GRACE_PERIOD = 60

#: Times a dead worker's trial is run again.
MAX_RETRY = 3

#: Tries to open a storage whose schema another worker is creating at the same moment.
_OPEN_TRIES = 10

#: The package that brings a SQLAlchemy driver, by the driver's name as SQLAlchemy resolves the
#: URL (SQLAlchemy 2.1 maps a plain ``postgresql://`` to psycopg 3, not to the sweep extra's
#: psycopg2, so the message names what is really missing and how to reach the one installed).
_DRIVERS = {"psycopg2": "psycopg2-binary (the sweep extra: pip install -e \".[sweep]\")",
            "psycopg": "psycopg 3, which SQLAlchemy uses for postgresql:// URLs (pip install "
                       "\"psycopg[binary]\"); or write postgresql+psycopg2://... to use the sweep "
                       "extra's psycopg2-binary",
            "mysqldb": "a MySQL driver such as PyMySQL (pip install pymysql; URL "
                       "mysql+pymysql://...)"}


def _driver_hint(url: str) -> str:
    """The package to install for the driver SQLAlchemy picks for ``url``."""
    from sqlalchemy.engine import make_url

    try:
        driver = make_url(url).get_driver_name()
    except Exception:  # noqa: BLE001 - an unparsable URL: name no package
        driver = ""
    return _DRIVERS.get(driver, f"its SQLAlchemy driver ({driver or 'unknown'})")


def _optuna():
    try:
        import optuna
    except ImportError as exc:  # pragma: no cover - exercised only without the extra
        raise ImportError('sweeps need optuna: pip install "qdensity[sweep]"') from exc
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def retried_from(trial) -> int | None:
    """The number of the dead trial that ``trial`` (a ``FrozenTrial``, or a running
    ``Trial``) runs again, or None.

    Examples
    --------
    >>> from qdensity.learning.sweep import MEMORY, open_study, retried_from, run_trials
    >>> study = open_study("fresh", MEMORY, seed=0, n_trials=1)
    >>> _ = run_trials(study, lambda trial: 1.0, 1)
    >>> retried_from(study.trials[0]) is None  # a first run, not a retry
    True
    """
    optuna = _optuna()
    if not hasattr(trial, "system_attrs"):  # a running Trial: read its stored record
        trial = next(t for t in trial.study.get_trials(deepcopy=False)
                     if t.number == trial.number)
    cls = getattr(optuna.storages, "RetryHeartbeatStaleTrialCallback", None) or \
        optuna.storages.RetryFailedTrialCallback
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return cls.retried_trial_number(trial)


def startup_trials(n_trials: int) -> int:
    """Random trials before TPE models the results: a quarter of the study, between 1 and 10
    (optuna's default of 10 would make a study of 10 trials or fewer random search).

    Examples
    --------
    >>> from qdensity.learning.sweep import startup_trials
    >>> [startup_trials(n) for n in (2, 8, 32, 100)]
    [1, 2, 8, 10]
    """
    return max(1, min(10, int(n_trials) // 4))


def _plain(value):
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if hasattr(value, "item") and getattr(value, "ndim", 1) == 0:
        return value.item()
    return type(value).__name__


def settings_hash(settings: Mapping) -> str:
    """Eight hex digits naming the settings (sorted JSON, SHA-256).

    Examples
    --------
    >>> from qdensity.learning.sweep import settings_hash
    >>> settings_hash({"a": 1, "b": [2, 3]}) == settings_hash({"b": (2, 3), "a": 1})  # order
    True
    >>> settings_hash({"a": 1}), settings_hash({"a": 1.0})  # JSON tells 1 from 1.0
    ('f9d86028', '742609b2')
    """
    text = json.dumps(_plain(settings), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def _sqlite_file(url: str) -> Path | None:
    if not url.startswith("sqlite"):
        return None
    from sqlalchemy.engine import make_url

    database = make_url(url).database
    return None if not database or database == ":memory:" else Path(database)


@contextlib.contextmanager
def _file_lock(path: Path | None):
    """An exclusive lock on ``path`` (POSIX ``flock``) while the schema is made; none where
    there is no file or no ``fcntl``."""
    if path is None:
        yield
        return
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: the retries alone
        yield
        return
    with open(path, "a+b") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _storage(optuna, url: str, grace_period: int | None):
    if url == MEMORY:
        return optuna.storages.InMemoryStorage()
    kwargs = {}
    with warnings.catch_warnings():  # heartbeats are "experimental" in optuna
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if grace_period is not None:
            kwargs = {"heartbeat_interval": max(1, int(grace_period) // 3),
                      "grace_period": int(grace_period)}
            new = getattr(optuna.storages, "RetryHeartbeatStaleTrialCallback", None)
            if new is not None:  # optuna >= 4.9
                kwargs["heartbeat_stale_trial_callback"] = new(max_retry=MAX_RETRY)
            else:  # pragma: no cover - older optuna
                kwargs["failed_trial_callback"] = optuna.storages.RetryFailedTrialCallback(
                    max_retry=MAX_RETRY)
        engine = {"connect_args": {"timeout": 60}} if url.startswith("sqlite") else None
        return optuna.storages.RDBStorage(url, engine_kwargs=engine, **kwargs)


def storage_object(storage) -> bool:
    """Whether ``storage`` is an optuna storage object (``RDBStorage``, ``JournalStorage``,
    ``InMemoryStorage``, any ``optuna.storages.BaseStorage``) rather than a URL string."""
    if isinstance(storage, str):
        return False
    return isinstance(storage, _optuna().storages.BaseStorage)


def in_memory(storage) -> bool:
    """Whether ``storage`` (a URL or an optuna storage object) keeps its trials in this
    process's memory only, so that no other process can share them."""
    if isinstance(storage, str):
        return storage == MEMORY or _sqlite_file(storage) is None and storage.startswith(
            "sqlite")
    return isinstance(storage, _optuna().storages.InMemoryStorage)


def _check_settings(study, settings: Mapping | None) -> None:
    if settings is None:
        return
    wanted = _plain(settings)
    stored = study.user_attrs.get("qdensity_settings")
    if stored is None:
        study.set_user_attr("qdensity_settings", wanted)
        return
    if stored != wanted:
        keys = list(dict.fromkeys([*stored, *wanted]))
        first = next(k for k in keys if stored.get(k) != wanted.get(k))
        raise ValueError(f"study {study.study_name!r} in this storage was made with other "
                         f"settings ({first}: {stored.get(first)!r} there, {wanted.get(first)!r} "
                         "now); name another study or storage, or leave the study name to its "
                         "default (derived from the settings)")


def open_study(study_name: str, storage, *, direction: str = "maximize",
               seed: int | None = None, n_trials: int = 32, settings: Mapping | None = None,
               grace_period: int | None = DEFAULT_GRACE_PERIOD) -> Study:
    """Create or load the study ``study_name`` in ``storage`` (see
    :func:`qdensity.learning.sweep.open_study`, which documents the parameters)."""
    optuna = _optuna()
    given = storage_object(storage)
    if not given and (not isinstance(storage, str)
                      or (storage != MEMORY and "://" not in storage)):
        raise ValueError(f"storage must be an optuna storage URL such as "
                         f"'sqlite:///sweep.db' or 'postgresql://user@host/db' (or {MEMORY!r}), "
                         f"or an optuna storage object (optuna.storages.BaseStorage: "
                         f"RDBStorage, JournalStorage, InMemoryStorage), got {storage!r}")
    if direction not in ("maximize", "minimize"):
        raise ValueError(f"direction must be 'maximize' or 'minimize', got {direction!r}")
    if grace_period is not None and (isinstance(grace_period, bool) or not isinstance(
            grace_period, int) or grace_period < 3):
        raise ValueError(f"grace_period must be an int of at least 3 seconds or None, got "
                         f"{grace_period!r}")
    from sqlalchemy.exc import DBAPIError, SQLAlchemyError

    db = None
    try:
        db = _sqlite_file(storage) if not given and storage != MEMORY else None
    except SQLAlchemyError as exc:
        raise ValueError(f"storage {storage!r} cannot be opened: {exc}") from exc
    if db is not None and not db.resolve().parent.is_dir():
        raise ValueError(f"storage {storage!r} cannot be opened: the directory "
                         f"{str(db.resolve().parent)!r} does not exist")
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=startup_trials(n_trials))
    last: Exception | None = None
    for attempt in range(_OPEN_TRIES):
        try:
            with _file_lock(None if db is None else db.with_name(db.name + ".lock")):
                rdb = storage if given else _storage(optuna, storage, grace_period)
                study = optuna.create_study(study_name=study_name, storage=rdb,
                                            direction=direction, sampler=sampler,
                                            load_if_exists=True)
                _check_settings(study, settings)
            break
        except ValueError:
            raise
        except ImportError as exc:
            hint = "its driver" if given else _driver_hint(storage)
            raise ImportError(f"storage {storage!r} needs a database driver that is not "
                              f"installed ({str(exc).splitlines()[0]}): install {hint}") from exc
        except DBAPIError as exc:  # the schema race (IntegrityError, OperationalError, ...)
            last = exc
            time.sleep(min(1.0, 0.05 * 2 ** attempt) * (0.5 + random.random()))
        except Exception as exc:  # noqa: BLE001 - a bad URL: SQLAlchemy raises many kinds
            raise ValueError(f"storage {storage!r} cannot be opened: {type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''}") from exc
    else:
        first = str(last).splitlines()[0] if last is not None and str(last) else ""
        raise ValueError(f"storage {storage!r} cannot be opened after {_OPEN_TRIES} tries: "
                         f"{type(last).__name__}: {first}") from last
    return study


def _int_seed(seed, name: str) -> int:
    """``seed`` as an int ``>= 0`` (the split and the sampler seeds are stored with the study,
    so a Generator or None is refused too), with a message naming ``name``."""
    seed = check_seed(seed, name)
    if not isinstance(seed, int):
        raise TypeError(f"{name} must be an int >= 0, got {type(seed).__name__} {seed!r}")
    return seed


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


def _absolute(storage):
    """An SQLite URL with its path made absolute (the same file for every worker); anything
    else (another URL, a storage object) as it is."""
    prefix = "sqlite:///"
    if storage_object(storage) or not isinstance(storage, str):
        return storage
    if storage.startswith(prefix) and not storage.startswith(prefix + "/") \
            and storage != prefix + ":memory:":
        return prefix + str(Path(storage[len(prefix):]).resolve())
    return storage
