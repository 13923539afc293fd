"""Units of work of an experiment run, their checkpoint files, and the merge of a seed's units.

A unit is one sub-configuration (a setting: a model, a depth) of one seed. Each finished unit
is written to ``<out>/<name>-<mode>.units/<settings hash>/seed<S>-unit<J>.json`` as it
arrives, so that a rerun of the same command (same settings) skips it; other settings have
another hash and never read it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from qdensity.io import atomic_write_text, check_readable

__all__ = ["normalise", "settings_hash", "checkpoint_dir", "load_unit", "save_unit",
           "merge_parts", "work_directory", "working_in"]

_WORKDIR: ContextVar[Path | None] = ContextVar("qdensity_experiment_workdir", default=None)


def _plain(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"a metric of type {type(obj).__name__} cannot be written to JSON")


def normalise(metrics: Mapping) -> dict:
    """The metrics as a JSON round trip gives them back (numpy scalars and arrays as Python
    numbers and lists, tuples as lists); floats keep every bit, NaN stays NaN."""
    return json.loads(json.dumps(metrics, default=_plain))


def settings_hash(settings: Mapping) -> str:
    """A short hash of the settings (sorted JSON)."""
    text = json.dumps(normalise(settings), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def checkpoint_dir(out: str | os.PathLike, name: str, mode: str, settings: Mapping) -> Path:
    """Where the units of this run (these settings) are written."""
    return Path(out) / f"{name}-{mode}.units" / settings_hash(settings)


def _unit_path(directory: Path, seed: int, unit: int) -> Path:
    return directory / f"seed{seed}-unit{unit}.json"


def _checksum(record: Mapping) -> str:
    """SHA-256 of a unit record's content (sorted JSON, the checksum field left out)."""
    body = {k: v for k, v in record.items() if k != "checksum"}
    text = json.dumps(body, sort_keys=True, default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()


def _why_unusable(record, seed: int) -> str | None:
    """What is wrong with a unit file's record (None when it can be used)."""
    if not isinstance(record, dict):
        return f"it holds a {type(record).__name__}, not a unit record"
    if record.get("checksum") != _checksum(record):
        return "its checksum does not match its content (edited, cut short or corrupted)"
    if not isinstance(record.get("metrics"), dict):
        return f"its metrics are {type(record.get('metrics')).__name__}, not a dict"
    if not isinstance(record.get("worker"), str):
        return f"its worker is {type(record.get('worker')).__name__}, not a str"
    if record.get("seed") != seed:
        return f"it is of seed {record.get('seed')!r}, not {seed}"
    return None


def load_unit(directory: Path, seed: int, unit: int, sub_config: Mapping) -> dict | None:
    """The record of a finished unit (``metrics``, ``worker``), or None: no file, another
    sub-configuration, or a file that cannot be trusted.

    A unit file is used only when it is UTF-8 JSON whose checksum (:func:`save_unit`) matches
    its content, with a dict of ``metrics`` and a ``worker`` string; anything else (cut short
    by a crash, binary, UTF-16, edited, a field missing, null or a list) is run again, with a
    ``UserWarning`` naming the file. The rerun overwrites it.
    """
    path = _unit_path(directory, seed, unit)
    if not path.is_file():
        return None
    try:
        record = json.loads(check_readable(path, max_bytes=2**28).read_text(encoding="utf-8"))
        why = _why_unusable(record, seed)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        why = f"it cannot be read as UTF-8 JSON ({type(exc).__name__})"
    if why is not None:
        warnings.warn(f"unit file {str(path)!r} is run again: {why}", UserWarning, stacklevel=2)
        return None
    if record.get("sub_config") != normalise(sub_config):
        return None
    return record


def save_unit(directory: Path, seed: int, unit: int, sub_config: Mapping, metrics: Mapping,
              worker: str) -> Path:
    """Write a finished unit atomically (a temporary file renamed into place), with the
    SHA-256 checksum of its content that :func:`load_unit` checks."""
    directory.mkdir(parents=True, exist_ok=True)
    path = _unit_path(directory, seed, unit)
    record = normalise({"seed": seed, "unit": unit, "sub_config": normalise(sub_config),
                        "worker": worker, "metrics": metrics})
    record["checksum"] = _checksum(record)
    atomic_write_text(path, json.dumps(record, default=_plain))
    return path


def merge_parts(parts: Sequence[Mapping]) -> dict:
    """One seed's metrics from its units' metrics: the flat keys and the ``curves`` of every
    part together; ``seconds`` summed. A key two parts both give with different values is an
    error: units must split a seed's work, not repeat it differently.
    """
    out: dict = {}
    curves: dict = {}
    seconds = 0.0
    for part in parts:
        for key, value in part.items():
            if key == "curves":
                clash = set(curves) & set(value)
                if clash:
                    raise ValueError(f"units give the same curves {sorted(clash)}")
                curves.update(value)
            elif key == "seconds":
                seconds += float(value)
            elif key in out and out[key] != value:
                raise ValueError(f"units give metric {key!r} different values: {out[key]!r} "
                                 f"and {value!r}")
            else:
                out[key] = value
    if curves:
        out["curves"] = curves
    if any("seconds" in p for p in parts) and math.isfinite(seconds):
        out["seconds"] = seconds
    return out


def work_directory() -> Path | None:
    """The run's ``out`` directory while a unit runs (None when the run writes nothing): where
    an experiment keeps state that a rerun resumes from (the ``moe`` sweeps' storage)."""
    return _WORKDIR.get()


@contextmanager
def working_in(directory: Path | None):
    """Set :func:`work_directory` for the duration of a unit."""
    token = _WORKDIR.set(None if directory is None else Path(directory))
    try:
        yield
    finally:
        _WORKDIR.reset(token)
