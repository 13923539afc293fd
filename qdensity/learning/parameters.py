"""Flat parameter vectors and parameter files for hybrid models (the "dressed" OrthoQNN, Fig. 11).

* :func:`get_flat` / :func:`set_flat` move every parameter of a layer (anything with a
  ``params`` dict, see :class:`qdensity.learning.nn.Layer`) or of a plain dict to and from one 1-d
  vector (the form the optimisers of :mod:`qdensity.learning.optim` work on).
* :func:`save_parameters` / :func:`load_parameters` store named arrays as plain ``.npz``
  (never pickle) or as JSON.

These functions only rely on a ``params`` mapping (duck typing), so this module does not
import the layers; :mod:`qdensity.learning.nn` re-exports all four names.
"""

from __future__ import annotations

import json
import math
import os
import re
import zipfile
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from qdensity.io import atomic_write, check_npz, check_readable

__all__ = ["get_flat", "set_flat", "save_parameters", "load_parameters", "MAX_PARAMETER_BYTES",
           "MAX_PARAMETER_ARRAYS"]

#: Default bound on the bytes a parameter file's arrays may take once read.
MAX_PARAMETER_BYTES = 2**31
#: Most arrays a parameter archive may hold.
MAX_PARAMETER_ARRAYS = 4096


# --------------------------------------------------------------------------------------------
# flat parameter vectors


def _as_mapping(target, name: str) -> Mapping[str, np.ndarray]:
    if isinstance(target, Mapping):
        return target
    if hasattr(target, "params") and isinstance(target.params, Mapping):
        return target.params
    raise TypeError(
        f"{name} must be a layer (with a params dict) or a dict of arrays, "
        f"got {type(target).__name__}"
    )


def get_flat(target) -> np.ndarray:
    """All arrays of a layer (its ``params``) or of a dict, concatenated into one vector.

    Parameters
    ----------
    target : Layer or dict[str, numpy.ndarray]
        A layer gives its ``params``; pass ``layer.grads`` to flatten the gradients in the
        same order.

    Returns
    -------
    numpy.ndarray, shape (P,), float64
        A copy; entries in the dict's key order, each array raveled in C order.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.learning.nn import Linear, get_flat
    >>> get_flat({"W": np.array([[1.0, 2.0], [3.0, 4.0]]), "b": np.array([5.0])}).tolist()
    [1.0, 2.0, 3.0, 4.0, 5.0]
    >>> get_flat(Linear(3, 2, seed=0)).shape  # W (3, 2) and b (2,)
    (8,)
    """
    mapping = _as_mapping(target, "target")
    if not mapping:
        return np.zeros(0)
    return np.concatenate([np.asarray(v, dtype=float).ravel() for v in mapping.values()])


def set_flat(target, flat) -> None:
    """Write a flat vector back into the arrays of a layer or dict, in place.

    Parameters
    ----------
    target : Layer or dict[str, numpy.ndarray]
        Order and sizes as in :func:`get_flat`.
    flat : array_like, shape (P,)
        ``P`` must equal the total number of entries; values must be finite.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.learning.nn import set_flat
    >>> params = {"W": np.zeros((2, 2)), "b": np.zeros(1)}
    >>> set_flat(params, [1.0, 2.0, 3.0, 4.0, 5.0])
    >>> params["W"].tolist(), params["b"].tolist()
    ([[1.0, 2.0], [3.0, 4.0]], [5.0])
    >>> set_flat(params, [1.0, 2.0])
    Traceback (most recent call last):
    ValueError: flat must have shape (5,) (one entry per parameter), got (2,)
    """
    mapping = _as_mapping(target, "target")
    total = int(sum(np.size(v) for v in mapping.values()))
    try:
        vec = np.asarray(flat, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"flat must be a vector of real numbers, got {flat!r}") from exc
    if vec.shape != (total,):
        raise ValueError(
            f"flat must have shape ({total},) (one entry per parameter), got {vec.shape}"
        )
    if not np.all(np.isfinite(vec)):
        raise ValueError("flat must be finite (no NaN or inf)")
    start = 0
    for key, arr in mapping.items():
        if not isinstance(arr, np.ndarray):
            raise TypeError(f"target[{key!r}] must be a numpy array to be written in place")
        arr[...] = vec[start : start + arr.size].reshape(arr.shape)
        start += arr.size


# --------------------------------------------------------------------------------------------
# saving


_NAME_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")
_JSON_FORMAT = "qdensity-parameters"


def _fortran(arr: np.ndarray) -> bool:
    """True where ``.npy`` stores the array in Fortran order (F- but not C-contiguous)."""
    return arr.ndim > 1 and arr.flags.f_contiguous and not arr.flags.c_contiguous


def _check_arrays(arrays: Mapping[str, Any]) -> dict[str, np.ndarray]:
    out = {}
    for name, value in arrays.items():
        if not _NAME_RE.match(name):
            raise ValueError(
                f"array name {name!r} is not allowed: use letters, digits, '_', '.' and '-'"
            )
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            raise TypeError(
                f"array {name!r} must hold real numbers or bools (stored without pickle), "
                f"got dtype {arr.dtype}"
            )
        out[name] = arr
    return out


def save_parameters(path: str | os.PathLike, /, **arrays) -> None:
    """Store named real arrays as plain ``.npz`` (no pickle) or, for ``*.json``, as JSON.

    Parameters
    ----------
    path : str or path-like
        Written exactly as given (no suffix appended). A name ending in ``.json`` (any case)
        is written as JSON, anything else as an uncompressed ``.npz`` archive (the layout of
        :func:`numpy.savez`, readable by :func:`numpy.load`).
    **arrays : array_like
        Real (bool, integer or float) arrays or scalars, e.g. ``**model.params`` or an
        optimiser's ``state_dict()``. Names may use letters, digits, ``_``, ``.`` and ``-``.

    Raises
    ------
    TypeError
        For object, string or complex arrays (they would need pickle or lose information).
    ValueError
        For bad names, and for NaN/inf (JSON cannot hold them; :func:`load_parameters`
        refuses them in either format).

    Notes
    -----
    JSON layout: ``{"format": "qdensity-parameters", "version": 1, "arrays": {name:
    {"dtype": ..., "shape": [...], "data": [flat list in C order]}}}``, plus ``"order": "F"``
    for an array held in Fortran order, which comes back in that layout (as from ``.npz``):
    matrix products depend on the layout in the last bit. Floats are written with ``repr``
    precision, so float64 values and the results computed from them round-trip exactly.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> from qdensity.learning.nn import save_parameters, load_parameters
    >>> d = tempfile.mkdtemp()
    >>> save_parameters(os.path.join(d, "p.json"), W=np.eye(2), t=3)
    >>> load_parameters(os.path.join(d, "p.json"))["W"]
    array([[1., 0.],
           [0., 1.]])
    """
    checked = _check_arrays(arrays)
    for name, arr in checked.items():
        if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            raise ValueError(f"array {name!r} has NaN or inf; parameter files hold finite values")
    path = os.fspath(path)
    if str(path).lower().endswith(".json"):
        doc: dict[str, Any] = {"format": _JSON_FORMAT, "version": 1, "arrays": {}}
        for name, arr in checked.items():
            if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
                raise ValueError(f"array {name!r} has NaN or inf, which JSON cannot store")
            doc["arrays"][name] = {
                "dtype": arr.dtype.str,
                "shape": list(arr.shape),
                "data": arr.ravel().tolist(),
            }
            if _fortran(arr):  # as .npy keeps it: the memory layout changes float results
                doc["arrays"][name]["order"] = "F"
        with atomic_write(path) as fh:
            json.dump(doc, fh, allow_nan=False)
        return
    # the layout of numpy.savez (one "<name>.npy" member per array, uncompressed), written
    # directly so that no array name can clash with a keyword of numpy.savez
    with atomic_write(path, "wb") as fh, zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_STORED,
                                                        allowZip64=True) as zf:
        for name, arr in checked.items():
            with zf.open(name + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, arr, allow_pickle=False)


def load_parameters(path: str | os.PathLike, *,
                    max_bytes: int | None = None) -> dict[str, np.ndarray]:
    """Read arrays written by :func:`save_parameters` (``.npz`` without pickle, or JSON).

    Parameters
    ----------
    path : str or path-like
        A ``*.json`` name is read as JSON, anything else with ``numpy.load(...,
        allow_pickle=False)``.
    max_bytes : int, optional
        Most bytes the arrays may take once read (default :data:`MAX_PARAMETER_BYTES`): an
        archive's members are measured by the sizes in its zip headers
        (``zipfile.ZipInfo.file_size``) before anything is inflated, a JSON file by its size
        on disk.

    Returns
    -------
    dict[str, numpy.ndarray]
        Arrays with their saved dtype and shape (0-d arrays for scalars).

    Raises
    ------
    ValueError
        Naming the file: if it is empty, damaged, holds NaN or inf, needs pickle (object
        arrays or a pickled object), is not an ``.npz``
        archive, or is not a qdensity parameter JSON file.

    Examples
    --------
    Arrays come back with their dtype and shape (a scalar as a 0-d array):

    >>> import os, tempfile
    >>> import numpy as np
    >>> from qdensity.learning.nn import load_parameters, save_parameters
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "model.npz")
    ...     save_parameters(path, theta=np.arange(3.0), step=np.int64(7))
    ...     loaded = load_parameters(path)
    >>> loaded["theta"].tolist(), loaded["step"].shape, loaded["step"].dtype
    ([0.0, 1.0, 2.0], (), dtype('int64'))
    """
    path = os.fspath(path)
    check_readable(path)  # not /dev/zero or a FIFO: they would be read forever or block
    limit = MAX_PARAMETER_BYTES if max_bytes is None else int(max_bytes)
    if str(path).lower().endswith(".json"):
        size = os.path.getsize(path)
        if size > 4 * limit:  # a float takes at most ~25 characters of JSON, 8 bytes in memory
            raise ValueError(f"{path!r} has {size} bytes, more than the {4 * limit} a parameter "
                             f"JSON file may have")
        return _load_json(path)
    return _load_npz(path, limit)


def _finite(path: str, name: str, arr: np.ndarray) -> np.ndarray:
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"{path!r}: array {name!r} holds NaN or inf; parameters must be finite")
    return arr


def _load_json(path: str) -> dict[str, np.ndarray]:
    with open(path, encoding="utf-8") as fh:
        try:
            doc = json.load(fh)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path!r} is not valid JSON: {exc}") from exc
        except RecursionError as exc:
            raise ValueError(f"{path!r} nests deeper than a parameter file does (a few levels)"
                             ) from exc
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path!r} is not a UTF-8 text (JSON) file: {exc}") from exc
    if not isinstance(doc, dict) or doc.get("format") != _JSON_FORMAT:
        raise ValueError(f"{path!r} is not a {_JSON_FORMAT!r} JSON file")
    arrays = doc.get("arrays", {})
    if not isinstance(arrays, dict):
        raise ValueError(f"{path!r}: 'arrays' must be an object of named arrays")
    out = {}
    for name, entry in arrays.items():
        try:
            dtype = np.dtype(entry["dtype"])
            shape = tuple(int(s) for s in entry["shape"])
            data = entry["data"]
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path!r}: entry {name!r} lacks a valid dtype/shape/data") from exc
        if dtype.kind not in "biuf":
            raise ValueError(f"{path!r}: entry {name!r} has unsupported dtype {dtype}")
        if any(s < 0 for s in shape):
            raise ValueError(f"{path!r}: entry {name!r} has a negative shape {list(shape)}")
        try:
            flat = np.asarray(data, dtype=dtype)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ValueError(f"{path!r}: entry {name!r} data are not {dtype} numbers") from exc
        if flat.ndim != 1 or flat.size != math.prod(shape):
            raise ValueError(f"{path!r}: entry {name!r} has {flat.size} values in data but "
                             f"shape {list(shape)} needs {math.prod(shape)} (a flat list)")
        order = entry.get("order", "C")
        if order not in ("C", "F"):
            raise ValueError(f"{path!r}: entry {name!r} has order {order!r}; allowed 'C' or 'F'")
        arr = flat.reshape(shape)
        out[name] = _finite(path, name, np.asfortranarray(arr) if order == "F" else arr)
    return out


def _load_npz(path: str, limit: int) -> dict[str, np.ndarray]:
    with open(path, "rb") as fh:  # FileNotFoundError / IsADirectoryError pass through
        head = fh.read(4)
    if head[:1] == b"\x80" or head[:1] == b"(":
        raise ValueError(f"{path!r} is a pickle, which is never loaded; parameters are read "
                         "without pickle (allow_pickle=False) from save_parameters' .npz files")
    if head[:4] == b"\x93NUM":
        raise ValueError(f"{path!r} holds a single .npy array, not an .npz archive of named "
                         "parameters")
    if head[:2] != b"PK":
        what = "an empty file" if not head else "not a zip archive"
        raise ValueError(f"{path!r} is not an .npz parameter archive ({what}); parameter "
                         "files are written by save_parameters")
    check_npz(path, limit, max_members=MAX_PARAMETER_ARRAYS)  # before numpy allocates
    try:
        loaded = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{path!r} is not a readable .npz parameter archive (damaged, or it "
                         f"needs pickle, which is never used): {exc}") from exc
    if not isinstance(loaded, np.lib.npyio.NpzFile):
        raise ValueError(
            f"{path!r} holds a single .npy array, not an .npz archive of named parameters"
        )
    with loaded:
        out = {}
        for name in loaded.files:
            try:
                arr = loaded[name]
            except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
                raise ValueError(f"{path!r}: array {name!r} cannot be read without pickle (the "
                                 f"file is damaged or holds objects): {exc}") from exc
            out[name] = _finite(path, name, arr)
        return out
