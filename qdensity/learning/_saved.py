"""Checks of a saved estimator file (:meth:`QNNClassifier.load`) before anything is built.

A file is data from outside: every field of its metadata and every array size is checked
against the others (and against the estimator's own template and layers) before a circuit
is built, so an edited or damaged file is refused with a message naming the field, never
by minutes of circuit building or an error deep inside Qiskit.
"""

from __future__ import annotations

import copy
import json
import numbers
import os

import numpy as np
from sklearn.decomposition import PCA
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from qdensity.circuits.ansatze.registry import FAMILIES
from qdensity.learning._spec import check_hyperparameters, encoded_width
from qdensity.learning.layer import History, QuantumLayer
from qdensity.learning.parameters import get_flat, load_parameters, save_parameters
from qdensity.models.density import DensityQNN
from qdensity.models.registry import DECOMPOSITIONS
from qdensity.validation import MAX_CIRCUIT_QUBITS, as_rng

FORMAT = "qdensity-estimator"
#: Version of the file layout written by ``save``.
FORMAT_VERSION = 1
SPEC_KEYS = ("ansatz", "decomposition", "depth", "mixture", "readout", "num_qubits", "constant",
             "scale")
_COMMON = {"format": str, "version": int, "estimator": str, "spec": dict, "template": bool,
           "n_features_in": int, "num_qubits": int, "data_columns": int, "post": bool,
           "pre": bool}
_OWN: dict[str, dict[str, type]] = {"QNNClassifier": {"classes": list, "classes_kind": str},
        "QNNRegressor": {"target_ndim": int, "num_targets": int}}

#: Most circuit angles a loaded spec may build (building costs about 1 ms an angle: a
#: round-robin or pyramid model on 128 qubits has 8,128 angles and builds in about 5 s; on
#: 1,000 qubits it would have 499,500 and take minutes).
MAX_LOADED_ANGLES = 2**14
#: Most bytes the arrays of an estimator file may inflate to (read from the zip headers).
MAX_ESTIMATOR_BYTES = 64 * 2**20

def spec_angles(spec: dict, num_qubits: int) -> int:
    """Circuit angles of the model a spec builds on ``num_qubits`` qubits (an upper bound
    with the cyclic decomposition, whose ``depth`` shifted copies carry their own angles),
    read off the family and decomposition registries before anything is built."""
    base = FAMILIES[spec["ansatz"]].parameter_count(num_qubits)
    return DECOMPOSITIONS[spec["decomposition"]].num_angles(base, spec["depth"])


def read_meta(data: dict, path) -> dict:
    """The metadata dict of a loaded file (removed from ``data``), format and version checked."""
    name = os.fspath(path)
    try:
        meta = json.loads(bytes(np.asarray(data.pop("meta")).astype(np.uint8)).decode())
    except (KeyError, ValueError, TypeError, UnicodeDecodeError, RecursionError) as exc:
        raise ValueError(f"{name!r} is not a saved qdensity estimator (no metadata; format "
                         f"{FORMAT!r} version {FORMAT_VERSION})") from exc
    if not isinstance(meta, dict):
        raise ValueError(f"{name!r}: the metadata must be a JSON object, got "
                         f"{type(meta).__name__}")
    if meta.get("format") != FORMAT or meta.get("version") != FORMAT_VERSION:
        raise ValueError(f"{name!r} has format {meta.get('format')!r} version "
                         f"{meta.get('version')!r}; this qdensity reads {FORMAT!r} version "
                         f"{FORMAT_VERSION}")
    return meta


def _field(meta: dict, key: str, kind: type, name: str):
    if key not in meta:
        raise ValueError(f"{name!r}: the metadata lacks {key!r} (the file is damaged or was "
                         f"not written by save)")
    value = meta[key]
    ok = isinstance(value, bool) if kind is bool else (
        isinstance(value, numbers.Integral) and not isinstance(value, bool) if kind is int
        else isinstance(value, kind))
    if not ok:
        raise ValueError(f"{name!r}: metadata field {key!r} must be a {kind.__name__}, got "
                         f"{value!r}")
    return value


def _size(data: dict, key: str, name: str) -> int:
    if key not in data:
        raise ValueError(f"{name!r} lacks the array {key!r}")
    return int(np.asarray(data[key]).size)


def check_saved(est, meta: dict, data: dict, path) -> dict:
    """Check every field of ``meta`` and every array of ``data`` for the estimator ``est``.

    Parameters
    ----------
    est : QNNClassifier or QNNRegressor
        The estimator loading the file (its template, ``pre`` and ``post`` take part).
    meta : dict
        The file's metadata (see :func:`read_meta`).
    data : dict of numpy.ndarray
        The file's arrays (``part{i}``, ``pca_components``, ``pca_mean``, ``scaler_mean``,
        ``scaler_scale``).
    path : path-like
        For the messages.

    Returns
    -------
    dict
        The model spec to set on ``est`` (empty for a template model).

    Raises
    ------
    ValueError
        Naming the file and the field or array that does not fit.
    """
    name = os.fspath(path)
    kind = type(est).__name__
    for key, typ in _COMMON.items():
        _field(meta, key, typ, name)
    if meta["estimator"] != kind:
        raise ValueError(f"{name!r} holds a {meta['estimator']}, not a {kind}")
    for key, typ in _OWN[kind].items():
        _field(meta, key, typ, name)
    n_in, n, cols = meta["n_features_in"], meta["num_qubits"], meta["data_columns"]
    if n_in < 1:
        raise ValueError(f"{name!r}: n_features_in must be >= 1, got {n_in}")
    if not 1 <= n <= MAX_CIRCUIT_QUBITS:
        raise ValueError(f"{name!r}: num_qubits must be in [1, {MAX_CIRCUIT_QUBITS}], got {n}")
    targets = _targets(meta, name, kind)
    spec: dict = {}
    if meta["template"]:
        model = est.model
        if not isinstance(model, DensityQNN):
            raise ValueError(f"{name!r} was saved from an estimator with a DensityQNN template; "
                             f"load it into one built with the same model= (got model="
                             f"{type(model).__name__})")
        if (model.num_qubits, model.num_features) != (n, n_in):
            raise ValueError(f"{name!r} holds a model of {n} qubits and {n_in} features; the "
                             f"template has {model.num_qubits} qubits and "
                             f"{model.num_features} features")
        width_q = model.num_parameters + model.mixture.params.size
    else:
        # files written before ``scale`` existed held unscaled models: read as scale=False
        spec = {"scale": False, **meta["spec"]} if isinstance(meta["spec"], dict) else {}
        if set(spec) != set(SPEC_KEYS):
            raise ValueError(f"{name!r}: the spec must hold exactly {list(SPEC_KEYS)}, got "
                             f"{sorted(spec)}")
        probe = copy.copy(est)
        probe.set_params(model=None, **spec)
        try:
            check_hyperparameters(probe)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name!r}: the saved spec is invalid: {exc}") from exc
        if encoded_width(probe, n_in) != (n, cols):
            raise ValueError(f"{name!r}: the spec and n_features_in={n_in} give "
                             f"{encoded_width(probe, n_in)} (qubits, data columns), but the "
                             f"file says ({n}, {cols})")
        angles = spec_angles(spec, n)
        if angles > MAX_LOADED_ANGLES:
            raise ValueError(f"{name!r}: its spec ({spec['ansatz']!r} on {n} qubits, "
                             f"decomposition {spec['decomposition']!r}) has {angles} circuit "
                             f"angles, more than the {MAX_LOADED_ANGLES} a loaded estimator may "
                             f"build (minutes of circuit building); refused before building")
        width_q = None
    readout = (est.model.readout if meta["template"] else spec["readout"])
    width = n if readout != "observable" else 1
    _check_arrays(est, meta, data, name, width, targets, width_q,
                  scaled=not meta["template"] and spec["scale"] is True)
    return spec


def _targets(meta: dict, name: str, kind: str) -> int:
    if kind == "QNNClassifier":
        classes = meta["classes"]
        if len(classes) < 2 or len(set(map(repr, classes))) != len(classes):
            raise ValueError(f"{name!r}: classes must list at least 2 distinct labels, got "
                             f"{classes!r:.200}")
        if not all(isinstance(c, (str, numbers.Real)) for c in classes):
            raise ValueError(f"{name!r}: classes must be numbers or strings, got "
                             f"{classes!r:.200}")
        return len(classes)
    ndim, m = meta["target_ndim"], meta["num_targets"]
    if ndim not in (1, 2) or m < 1 or (ndim == 1 and m != 1):
        raise ValueError(f"{name!r}: target_ndim={ndim!r} with num_targets={m!r}; allowed: "
                         f"target_ndim 1 with 1 target, or 2 with >= 1 targets")
    return m


def _check_arrays(est, meta, data, name, width, targets, width_q, scaled: bool) -> None:
    parts = 1 + int(meta["pre"]) + int(meta["post"])
    want = {f"part{i}" for i in range(parts)}
    n_in, cols = meta["n_features_in"], meta["data_columns"]
    pca = not meta["template"] and cols < n_in
    if pca:
        want |= {"pca_components", "pca_mean"}
    if scaled:
        want |= {"scaler_mean", "scaler_scale"}
        for key in ("scaler_mean", "scaler_scale"):
            if key in data and np.shape(data[key]) != (n_in,):
                raise ValueError(f"{name!r}: {key} has shape {np.shape(data[key])}, expected "
                                 f"({n_in},) (n_features_in)")
    if set(data) != want:
        raise ValueError(f"{name!r} holds the arrays {sorted(data)}; its metadata needs "
                         f"exactly {sorted(want)}")
    if pca:
        for key, shape in (("pca_components", (cols, n_in)), ("pca_mean", (n_in,))):
            if np.shape(data[key]) != shape:
                raise ValueError(f"{name!r}: {key} has shape {np.shape(data[key])}, expected "
                                 f"{shape} (data_columns, n_features_in)")
    if meta["pre"] != (est.pre is not None):
        raise ValueError(f"{name!r} was saved {'with' if meta['pre'] else 'without'} a pre "
                         f"layer; this estimator has pre={est.pre!r:.60}")
    if meta["pre"]:
        expected = get_flat(est.pre.params).size
        if _size(data, "part0", name) != expected:
            raise ValueError(f"{name!r}: part0 (pre) has {_size(data, 'part0', name)} entries, "
                             f"expected {expected}")
    q = f"part{int(meta['pre'])}"
    if width_q is not None and _size(data, q, name) != width_q:
        raise ValueError(f"{name!r}: {q} (the model's angles and mixture) has "
                         f"{_size(data, q, name)} entries; the template has {width_q}")
    if width_q is None and _size(data, q, name) < spec_angles(meta["spec"],
                                                               meta["num_qubits"]):
        raise ValueError(f"{name!r}: {q} has {_size(data, q, name)} entries, too few for its "
                         f"spec on {meta['num_qubits']} qubits (its circuit alone has "
                         f"{spec_angles(meta['spec'], meta['num_qubits'])} angles)")
    if meta["post"]:
        post = f"part{parts - 1}"
        if isinstance(est.post, str):
            expected = width * targets + targets  # Linear(width, targets) with bias
        elif est.post is None:
            raise ValueError(f"{name!r} was saved with a post layer; this estimator has "
                             f"post=None")
        else:
            expected = get_flat(est.post.params).size
        if _size(data, post, name) != expected:
            raise ValueError(f"{name!r}: {post} (post) has {_size(data, post, name)} entries, "
                             f"expected {expected} for {width} model output(s) and "
                             f"{targets} target(s)")
    elif est.post is not None:
        raise ValueError(f"{name!r} was saved with post=None; load it into an estimator built "
                         f"with post=None (this one has post={est.post!r:.60})")
    elif width != targets:
        raise ValueError(f"{name!r} has no post layer, so the model's {width} output(s) must "
                         f"equal its {targets} target(s)")


def _plain(value):
    """A numpy scalar hyperparameter (``epochs=np.int64(5)``) as the Python value it means."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} {value!r:.60} cannot be saved in JSON")


def write_estimator(est, path) -> None:
    """Write a fitted estimator's metadata and arrays (the body of ``save``)."""
    meta = {"format": FORMAT, "version": FORMAT_VERSION, "estimator": type(est).__name__,
            "spec": {k: getattr(est, k) for k in SPEC_KEYS},
            "template": est.model is not None, "n_features_in": int(est.n_features_in_),
            "num_qubits": int(est.num_qubits_), "data_columns": int(est._data_columns_),
            "post": est.post_ is not None, "pre": est.pre_ is not None}
    meta.update(est._meta())
    arrays = {f"part{i}": get_flat(p.params) for i, p in enumerate(est._parts())}
    if est.pca_ is not None:
        arrays.update(pca_components=est.pca_.components_, pca_mean=est.pca_.mean_)
    if est.scaler_ is not None:
        arrays.update(scaler_mean=est.scaler_.mean_, scaler_scale=est.scaler_.scale_)
    arrays["meta"] = np.frombuffer(json.dumps(meta, default=_plain).encode(), dtype=np.uint8)
    save_parameters(path, **arrays)


def read_estimator(est, path):
    """Check a saved file, then restore ``est`` from it (the body of ``load``)."""
    data = load_parameters(path, max_bytes=MAX_ESTIMATOR_BYTES)
    meta = read_meta(data, path)
    spec = check_saved(est, meta, data, path)
    if not meta["template"]:  # the file's spec defines the model
        est.set_params(model=None, **spec)
    est.n_features_in_ = meta["n_features_in"]
    est._load_meta(meta)
    est._prepare(np.zeros((1, est.n_features_in_)), as_rng(0), fit_pca=False)
    est.layer_ = QuantumLayer(est.model_, "exact")
    if "scaler_mean" in data:
        est.scaler_ = StandardScaler()
        est.scaler_.mean_ = data.pop("scaler_mean")
        est.scaler_.scale_ = data.pop("scaler_scale")
        est.scaler_.var_ = est.scaler_.scale_**2
        est.scaler_.n_features_in_ = est.n_features_in_
    if "pca_components" in data:
        est.pca_ = PCA(n_components=meta["data_columns"])
        est.pca_.components_ = data.pop("pca_components")
        est.pca_.mean_ = data.pop("pca_mean")
        est.pca_.n_features_in_ = est.n_features_in_
    flat = []
    for i, part in enumerate(est._parts()):
        arr = data[f"part{i}"]
        want = get_flat(part.params).size
        if arr.size != want:  # the model's angles: known once it is built
            raise ValueError(f"parameters part{i} in {os.fspath(path)!r} have {arr.size} "
                             f"entries, expected {want}")
        flat.append(np.asarray(arr, dtype=float).ravel())
    est._set(np.concatenate(flat))
    est.history_ = History()
    est.stopped_by_budget_ = False
    return est


class SavedMixin:
    """``save`` / ``load`` of the QNN estimators (:func:`write_estimator`,
    :func:`read_estimator`)."""

    def save(self, path) -> None:
        """Save everything ``predict`` needs (``.json`` or ``.npz``; never pickle).

        The file records its format version, the estimator's class, the model spec, the
        learned classes and feature count, the PCA step and all trained parameters.
        """
        check_is_fitted(self, "model_")
        write_estimator(self, path)

    def load(self, path):
        """Restore an estimator saved by :meth:`save`; returns ``self``, ready to ``predict``.

        Every metadata field and array size is checked against the others (and against this
        estimator's template, ``pre`` and ``post``) before any circuit is built.

        Raises
        ------
        ValueError
            Naming the file and the field: another format or version, another estimator
            class, a missing or ill-typed field (e.g. no ``classes``), an invalid spec, or
            arrays whose sizes do not fit the model.
        """
        return read_estimator(self, path)
