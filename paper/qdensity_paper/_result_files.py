"""Results files: written atomically under a lock, read back only after their fields check.

A results file is written with :func:`qdensity.io.atomic_write_text` (a temporary file in the
same folder, flushed to disk and renamed over the old one), so a crash or a full disk leaves
the old file whole. Runs
that share a folder take an exclusive ``fcntl.flock`` on ``.<file>.lock`` beside it while they
read, merge and write, so two runs finishing together both keep their seeds.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from qdensity.io import check_readable
from qdensity.validation import FileName

__all__ = ["locked", "check_fields", "close_enough", "read_fields",
           "canonical", "jsonable", "recomputed"]


#: Largest results file read (the committed ones take a few MB).
MAX_RESULT_BYTES = 256 * 2**20

#: What a result's name, mode and figures may be (each becomes a file name).
_FILE_NAME = FileName()


@contextmanager
def locked(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``.<name>.lock`` beside ``path`` (POSIX ``flock``)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    lock = path.with_name(f".{path.name}.lock")
    with open(lock, "a+") as handle:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def _is_seed(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and bool(value >= 0)


#: Field -> (allowed types, what the message calls them).
_FIELDS = {"name": (str, "a str"), "mode": (str, "a str"), "config": (dict, "a dict"),
           "seeds": (list, "a list of non-negative ints"),
           "looks": (list, "a list of seed lists"),
           "per_seed": (list, "a list of dicts (one per seed)"),
           "summary": (dict, "a dict"), "curves": (dict, "a dict"),
           "figures": (list, "a list of file names"), "versions": (dict, "a dict"),
           "created": (str, "a str")}


def check_fields(fields: Mapping, where: str) -> None:
    """Refuse fields of a result that a file or a caller got wrong.

    Parameters
    ----------
    fields : mapping
        ``ExperimentResult`` fields.
    where : str
        Named in the message (``"results file 'x.json'"``, ``"ExperimentResult"``).

    Raises
    ------
    TypeError, ValueError
        Naming ``where``, the field and what it holds.
    """
    for key, (kind, what) in _FIELDS.items():
        if key in fields and not isinstance(fields[key], kind):
            raise TypeError(f"{where}: {key} must be {what}, got {type(fields[key]).__name__}")
    for key in ("name", "mode"):  # both name files: never a path
        if key in fields and not _FILE_NAME.is_satisfied_by(fields[key]):
            raise ValueError(f"{where}: {key} must be {_FILE_NAME}, got {fields[key]!r:.80}")
    seeds = fields.get("seeds", [])
    bad = [s for s in seeds if not _is_seed(s)]
    if bad:
        raise ValueError(f"{where}: seeds must be non-negative ints, got {bad[0]!r}")
    if len(set(map(int, seeds))) != len(seeds):
        raise ValueError(f"{where}: seeds must not repeat, got {list(seeds)}")
    for look in fields.get("looks", []):
        if not isinstance(look, list) or not all(_is_seed(s) for s in look):
            raise TypeError(f"{where}: looks must be a list of seed lists, got {look!r}")
    rows = fields.get("per_seed", [])
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise TypeError(f"{where}: per_seed[{i}] must be a dict of metrics, got "
                            f"{type(row).__name__}")
    figures = fields.get("figures", [])
    if any(not isinstance(f, str) for f in figures):
        raise TypeError(f"{where}: figures must be a list of file names (str)")
    bad = [f for f in figures if not _FILE_NAME.is_satisfied_by(f)]
    if bad:
        raise ValueError(f"{where}: figures must be file names in the results folder (never "
                         f"paths), got {bad[0]!r:.80}")
    seconds = fields.get("seconds")
    if seconds is not None and (isinstance(seconds, bool)
                                or not isinstance(seconds, (int, float, np.number))
                                or not math.isfinite(float(seconds)) or float(seconds) < 0):
        raise ValueError(f"{where}: seconds must be a finite number >= 0 or None, got "
                         f"{seconds!r}")


def close_enough(a, b, rtol: float = 1e-9) -> bool:
    """Whether two JSON-like values agree (floats to ``rtol``; NaN and None alike)."""
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return set(a) == set(b) and all(close_enough(a[k], b[k], rtol) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(close_enough(x, y, rtol) for x, y in zip(a, b, strict=True))
    missing = (None,)
    if (a in missing or _nan(a)) and (b in missing or _nan(b)):
        return True
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) \
            and not isinstance(a, bool) and not isinstance(b, bool):
        return math.isclose(float(a), float(b), rel_tol=rtol, abs_tol=1e-12)
    return a == b


def _nan(x) -> bool:
    return isinstance(x, float) and math.isnan(x)


def canonical(obj) -> str:
    """Sorted JSON of ``obj`` (for comparing settings)."""
    return json.dumps(obj, sort_keys=True, default=str)


def read_fields(path: Path, version: int, allowed: set[str], where: str) -> dict:
    """The fields of a results file of format ``version``, their types checked.

    Raises
    ------
    ValueError, TypeError
        Naming ``where``: unreadable (not UTF-8 JSON), another format, unknown or missing
        fields, a field of the wrong type, seeds that are not distinct non-negative ints,
        seeds and per-seed rows of different lengths.
    """
    try:  # a regular file of bounded size (not /dev/zero or a FIFO), then its JSON
        data = json.loads(check_readable(path, where, max_bytes=MAX_RESULT_BYTES).read_text(
            encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"cannot read {where}: {exc}") from exc
    except RecursionError as exc:
        raise ValueError(f"cannot read {where}: nested deeper than a results file") from exc
    if not isinstance(data, dict) or data.get("format") != version:
        found = data.get("format") if isinstance(data, dict) else None
        raise ValueError(f"{str(path)!r} is not a qdensity results file of format "
                         f"{version} (found format {found!r})")
    data.pop("format")
    unknown = sorted(set(data) - allowed)
    missing = sorted({"name", "mode", "config", "seeds", "per_seed"} - set(data))
    if unknown or missing:
        raise ValueError(f"{where}: unknown fields {unknown}, missing fields {missing}")
    check_fields(data, where)
    if len(data["seeds"]) != len(data["per_seed"]):
        raise ValueError(f"{where}: {len(data['seeds'])} seeds but {len(data['per_seed'])} "
                         f"per_seed rows")
    return data


def jsonable(obj):
    """``obj`` with numpy values as Python ones and NaN/inf as None (JSON has none)."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None  # JSON has no NaN; a missing spread reads as null
    return obj


def recomputed(data: Mapping, where: str, summarise: Callable, curve_summary: Callable,
               mean_ci: Callable) -> dict:
    """``summary`` and ``curves`` of a results file's fields, recomputed from its rows.

    Where the stored ones disagree, a ``UserWarning`` names the file and the recomputed ones
    are returned; a stored summary that agrees (clipped to the metric's range or, as files
    written before clipping hold, not) is kept as stored.
    """
    out: dict = {}
    stored = {"summary": data.get("summary", {}), "curves": data.get("curves", {})}
    rows = data["per_seed"]
    try:
        fresh = {"summary": jsonable(summarise(rows)) if rows else {},
                 "curves": jsonable(curve_summary(rows))}
        # files written before intervals were clipped to the metric's range hold the
        # unclipped Student-t interval (and no flags): that agrees with the rows too
        raw = {k: jsonable(mean_ci([r[k] for r in rows])) for k in fresh["summary"]}
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"{where}: its per-seed rows cannot be summarised: {exc}") from exc
    if set(stored["summary"]) == set(fresh["summary"]) and all(
            isinstance(v, dict) and {"mean", "low", "high"} <= set(v)
            and any(close_enough(v, {f: ref[k].get(f) for f in v}) for ref in (fresh[
                "summary"], raw)) for k, v in stored["summary"].items()):
        fresh["summary"] = stored["summary"]
    for key in ("summary", "curves"):
        if not close_enough(stored[key], fresh[key]):
            warnings.warn(f"{where}: the stored {key} disagrees with its per-seed rows; "
                          f"showing the {key} recomputed from them", UserWarning,
                          stacklevel=3)
        out[key] = fresh[key]
    return out
