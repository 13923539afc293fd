"""Classical layers around a quantum layer: the "dressed" OrthoQNN of the paper (Fig. 11).

The paper's OrthoQNN experiments (Fig. 11a, Supp. "Hyperparameters") wrap the quantum layer in
classical pre- and post-processing::

    x' = Linear(784 -> n)(image)      # pre-processing
    x  = ReLU(x')                     # sigma(x') in the paper
    y  = QNN(Load(x / ||x||))         # unary loader + (density) OrthoQNN, outputs a vector y
    p  = Softmax(Linear(n -> 10)(y))  # post-processing into class probabilities

and the mixture-of-experts gates of Supp. H (eq. 58 and "MoE*") compute
``alpha(x) = softmax(GELU(Linear(sigma(x'))))``. This module supplies those classical pieces
in plain numpy, each with an explicit ``forward`` and ``backward`` (a vector-Jacobian
product), so that a training loop can chain them with a quantum layer's own
forward/backward:

* :class:`Layer` -- the protocol: ``forward(X) -> Y`` caches what ``backward`` needs,
  ``backward(grad_Y) -> grad_X`` stores parameter gradients in ``grads`` (same keys and shapes
  as ``params``) and returns the gradient with respect to the input.
* :class:`Linear`, :class:`ReLU`, :class:`GELU`, :class:`Softmax`, :class:`Normalize`,
  :class:`Sequential`.
* :func:`get_flat` / :func:`set_flat` move every parameter to and from one 1-d vector (the
  form the optimisers of :mod:`qdensity.optim` work on).
* :func:`save_parameters` / :func:`load_parameters` store named arrays as plain ``.npz``
  (never pickle) or as JSON.

Shapes: every layer maps a batch ``X`` of shape ``(B, d_in)`` to ``(B, d_out)``; all
arithmetic is float64.
"""

from __future__ import annotations

import abc
import json
import math
import os
import re
import zipfile
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.special import erf

from qdensity.validation import SeedLike, as_rng, check_positive_int

__all__ = [
    "Layer",
    "Linear",
    "ReLU",
    "GELU",
    "Softmax",
    "Normalize",
    "Sequential",
    "get_flat",
    "set_flat",
    "save_parameters",
    "load_parameters",
]


# --------------------------------------------------------------------------------------------
# input checks


def _check_batch(X, name: str, features: int | None = None) -> np.ndarray:
    """A finite float64 array of shape ``(B, d)`` with ``B >= 1`` (and ``d == features``)."""
    try:
        arr = np.asarray(X, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {X!r}") from exc
    want = "(batch, features)" if features is None else f"(batch, {features})"
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-dimensional with shape {want}, got shape {arr.shape}")
    if arr.shape[0] < 1:
        raise ValueError(f"{name} must hold at least one row, got shape {arr.shape}")
    if features is not None and arr.shape[1] != features:
        raise ValueError(f"{name} must have shape {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def _check_grad(grad_Y, shape: tuple[int, ...], name: str = "grad_Y") -> np.ndarray:
    """A finite float64 array with exactly the shape of the layer's last output."""
    try:
        arr = np.asarray(grad_Y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {grad_Y!r}") from exc
    if arr.shape != shape:
        raise ValueError(
            f"{name} must have the shape of the last forward output {shape}, got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


# --------------------------------------------------------------------------------------------
# the protocol


class Layer(abc.ABC):
    """A differentiable map of batches, ``(B, d_in) -> (B, d_out)``, with named parameters.

    Subclasses implement :meth:`forward` and :meth:`backward`. ``forward`` caches what
    ``backward`` needs (so ``backward`` refers to the most recent ``forward``);
    ``backward`` overwrites ``grads`` with the gradient of the scalar loss with respect to
    each parameter and returns the gradient with respect to the layer's input.

    Attributes
    ----------
    params : dict[str, numpy.ndarray]
        Trainable arrays, updated in place by :func:`set_flat`.
    grads : dict[str, numpy.ndarray]
        Same keys and shapes as ``params``; zeros until the first ``backward``.
    """

    def __init__(self) -> None:
        self.params: dict[str, np.ndarray] = {}
        self.grads: dict[str, np.ndarray] = {}
        self._out_shape: tuple[int, ...] | None = None

    @abc.abstractmethod
    def forward(self, X) -> np.ndarray:
        """Apply the layer to a batch.

        Parameters
        ----------
        X : array_like, shape (B, d_in)

        Returns
        -------
        numpy.ndarray, shape (B, d_out)
        """

    @abc.abstractmethod
    def backward(self, grad_Y) -> np.ndarray:
        """Vector-Jacobian product for the most recent :meth:`forward`.

        Parameters
        ----------
        grad_Y : array_like, shape (B, d_out)
            Gradient of the scalar loss with respect to the last output.

        Returns
        -------
        numpy.ndarray, shape (B, d_in)
            Gradient of the loss with respect to the last input. Parameter gradients are
            stored in ``grads``.
        """

    def __call__(self, X) -> np.ndarray:
        return self.forward(X)

    @property
    def num_parameters(self) -> int:
        """Total number of trainable scalars."""
        return int(sum(p.size for p in self.params.values()))

    def zero_grad(self) -> None:
        """Set every entry of ``grads`` to zero."""
        for g in self.grads.values():
            g.fill(0.0)

    def _need_forward(self) -> tuple[int, ...]:
        if self._out_shape is None:
            raise RuntimeError(
                f"{type(self).__name__}.backward was called before forward; call forward first"
            )
        return self._out_shape


# --------------------------------------------------------------------------------------------
# layers


class Linear(Layer):
    r"""Affine map ``Y = X W + b``.

    Weights are drawn Glorot-uniform (Glorot & Bengio 2010):
    ``W ~ U(-a, a)``, ``a = sqrt(6 / (in_features + out_features))``; the bias starts at zero.
    In the paper this is the ``784 x 8`` pre-processing and the ``8 x 10`` post-processing
    layer of Fig. 11a, and the gating network ``Linear`` of Supp. H (eq. 58).

    Parameters
    ----------
    in_features : int
        Input width ``d_in``.
    out_features : int
        Output width ``d_out``.
    seed : int, numpy.random.Generator or None
        Source of the initial weights; equal seeds give equal weights.
    bias : bool
        Whether to add the bias ``b``.

    Attributes
    ----------
    params : dict
        ``"W"``: shape ``(d_in, d_out)``; ``"b"``: shape ``(d_out,)`` (only if ``bias``).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.nn import Linear
    >>> layer = Linear(3, 2, seed=0)
    >>> Y = layer.forward(np.ones((4, 3)))
    >>> Y.shape
    (4, 2)
    >>> layer.backward(np.ones((4, 2))).shape
    (4, 3)
    >>> layer.grads["b"]
    array([4., 4.])
    """

    def __init__(
        self, in_features: int, out_features: int, seed: SeedLike = None, bias: bool = True
    ) -> None:
        super().__init__()
        self.in_features = check_positive_int(in_features, "in_features")
        self.out_features = check_positive_int(out_features, "out_features")
        if not isinstance(bias, (bool, np.bool_)):
            raise TypeError(f"bias must be a bool, got {bias!r}")
        self.bias = bool(bias)
        rng = as_rng(seed)
        limit = math.sqrt(6.0 / (self.in_features + self.out_features))
        self.params["W"] = rng.uniform(-limit, limit, size=(self.in_features, self.out_features))
        self.grads["W"] = np.zeros_like(self.params["W"])
        if self.bias:
            self.params["b"] = np.zeros(self.out_features)
            self.grads["b"] = np.zeros(self.out_features)
        self._X: np.ndarray | None = None

    def forward(self, X) -> np.ndarray:
        """``Y = X W + b``; ``X`` shape ``(B, in_features)``, ``Y`` shape ``(B, out_features)``."""
        X = _check_batch(X, "X", self.in_features)
        self._X = X
        Y = X @ self.params["W"]
        if self.bias:
            Y = Y + self.params["b"]
        self._out_shape = Y.shape
        return Y

    def backward(self, grad_Y) -> np.ndarray:
        """``grads["W"] = X^T G``, ``grads["b"] = sum_rows G``; returns ``G W^T`` (B, d_in)."""
        G = _check_grad(grad_Y, self._need_forward())
        self.grads["W"][...] = self._X.T @ G
        if self.bias:
            self.grads["b"][...] = G.sum(axis=0)
        return G @ self.params["W"].T

    def __repr__(self) -> str:
        return f"Linear({self.in_features}, {self.out_features}, bias={self.bias})"


class ReLU(Layer):
    """Element-wise ``max(x, 0)`` (the paper's ``sigma`` in Fig. 11a).

    The derivative at exactly ``x = 0`` is taken as 0. Shapes: ``(B, d) -> (B, d)``.
    """

    def __init__(self) -> None:
        super().__init__()
        self._mask: np.ndarray | None = None

    def forward(self, X) -> np.ndarray:
        """``max(X, 0)`` element-wise; shape ``(B, d)``."""
        X = _check_batch(X, "X")
        self._mask = X > 0
        self._out_shape = X.shape
        return np.where(self._mask, X, 0.0)

    def backward(self, grad_Y) -> np.ndarray:
        """``grad_Y * [X > 0]``; shape ``(B, d)``."""
        G = _check_grad(grad_Y, self._need_forward())
        return np.where(self._mask, G, 0.0)

    def __repr__(self) -> str:
        return "ReLU()"


_SQRT_2_OVER_PI = math.sqrt(2.0 / math.pi)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
_GELU_TANH_C = 0.044715


class GELU(Layer):
    r"""Gaussian error linear unit ``x Phi(x)``: the activation of the "MoE*" gate (Supp. H).

    Reference: Hendrycks & Gimpel (2016).

    Parameters
    ----------
    approximate : {"none", "tanh"}
        ``"none"`` (default) is the exact form ``GELU(x) = x (1 + erf(x / sqrt 2)) / 2`` with
        :func:`scipy.special.erf`, derivative ``Phi(x) + x phi(x)``. ``"tanh"`` is the
        approximation ``x (1 + tanh(sqrt(2/pi) (x + 0.044715 x^3))) / 2`` and its exact
        derivative. The names and the default follow ``torch.nn.GELU``.

    Notes
    -----
    Shapes: ``(B, d) -> (B, d)``.
    """

    def __init__(self, approximate: str = "none") -> None:
        super().__init__()
        if approximate not in ("none", "tanh"):
            raise ValueError(f"approximate must be 'none' or 'tanh', got {approximate!r}")
        self.approximate = approximate
        self._dY: np.ndarray | None = None

    def forward(self, X) -> np.ndarray:
        """``GELU(X)`` element-wise; shape ``(B, d)``."""
        X = _check_batch(X, "X")
        if self.approximate == "none":
            cdf = 0.5 * (1.0 + erf(X / math.sqrt(2.0)))
            pdf = _INV_SQRT_2PI * np.exp(-0.5 * X * X)
            Y = X * cdf
            self._dY = cdf + X * pdf
        else:
            u = _SQRT_2_OVER_PI * (X + _GELU_TANH_C * X**3)
            t = np.tanh(u)
            Y = 0.5 * X * (1.0 + t)
            du = _SQRT_2_OVER_PI * (1.0 + 3.0 * _GELU_TANH_C * X * X)
            self._dY = 0.5 * (1.0 + t) + 0.5 * X * (1.0 - t * t) * du
        self._out_shape = X.shape
        return Y

    def backward(self, grad_Y) -> np.ndarray:
        """``grad_Y * GELU'(X)``; shape ``(B, d)``."""
        G = _check_grad(grad_Y, self._need_forward())
        return G * self._dY

    def __repr__(self) -> str:
        return f"GELU(approximate={self.approximate!r})"


class Softmax(Layer):
    r"""Row-wise ``softmax(z)_k = exp(z_k) / sum_j exp(z_j)``.

    Post-processing of Fig. 11a and the mixture gate ``alpha_k(x) = softmax_k(...)`` of
    Supp. H (eq. 58). Computed as ``exp(z - max z)`` so logits of any finite size are safe.

    Notes
    -----
    Shapes: ``(B, C) -> (B, C)``, every output row on the probability simplex.
    The backward pass applies the full Jacobian ``diag(s) - s s^T`` of each row:
    ``grad_z = s * (g - <g, s>)``. For a classifier,
    :func:`qdensity.losses.cross_entropy_with_logits` on the logits is the numerically safer
    pairing than ``Softmax`` followed by :func:`qdensity.losses.cross_entropy`.
    """

    def __init__(self) -> None:
        super().__init__()
        self._S: np.ndarray | None = None

    def forward(self, X) -> np.ndarray:
        """Row-wise softmax of ``X``, shape ``(B, C)``."""
        X = _check_batch(X, "X")
        Z = X - X.max(axis=1, keepdims=True)
        E = np.exp(Z)
        S = E / E.sum(axis=1, keepdims=True)
        self._S = S
        self._out_shape = S.shape
        return S

    def backward(self, grad_Y) -> np.ndarray:
        """``S * (G - rowsum(G * S))``, shape ``(B, C)``."""
        G = _check_grad(grad_Y, self._need_forward())
        S = self._S
        return S * (G - np.sum(G * S, axis=1, keepdims=True))

    def __repr__(self) -> str:
        return "Softmax()"


class Normalize(Layer):
    r"""Row-wise L2 normalisation ``x / ||x||``: the ``x / ||x||`` a unary loader encodes.

    Fig. 11a loads ``|x> ∝ sum_j x_j |e_j>``; this layer makes the proportionality explicit
    and differentiable, so the gradient flows through the normalisation into the
    pre-processing layers.

    Raises
    ------
    ValueError
        In ``forward`` if a row is all zeros (it has no direction). This can happen after a
        ReLU; nothing is replaced silently.

    Notes
    -----
    Shapes: ``(B, d) -> (B, d)``. With ``y = x / ||x||`` the backward pass is
    ``grad_x = (g - y <y, g>) / ||x||``.
    """

    def __init__(self) -> None:
        super().__init__()
        self._Y: np.ndarray | None = None
        self._norm: np.ndarray | None = None

    def forward(self, X) -> np.ndarray:
        """Each row divided by its Euclidean norm; shape ``(B, d)``."""
        X = _check_batch(X, "X")
        norm = np.linalg.norm(X, axis=1, keepdims=True)
        zero = np.flatnonzero(norm[:, 0] == 0.0)
        if zero.size:
            raise ValueError(
                f"X has all-zero rows {zero.tolist()[:10]} (of {X.shape[0]}); "
                "a zero vector cannot be normalised for a unary loader"
            )
        Y = X / norm
        self._Y, self._norm = Y, norm
        self._out_shape = Y.shape
        return Y

    def backward(self, grad_Y) -> np.ndarray:
        """``(G - Y rowsum(G * Y)) / ||X||``, shape ``(B, d)``."""
        G = _check_grad(grad_Y, self._need_forward())
        Y = self._Y
        return (G - Y * np.sum(G * Y, axis=1, keepdims=True)) / self._norm

    def __repr__(self) -> str:
        return "Normalize()"


def _is_layer_like(obj: Any) -> bool:
    return all(hasattr(obj, a) for a in ("forward", "backward", "params", "grads"))


class Sequential(Layer):
    """Layers applied one after the other; backward runs them in reverse.

    Any object with ``forward``, ``backward``, ``params`` and ``grads`` can be a member (a
    quantum layer included). ``params`` and ``grads`` are flattened with prefixed keys
    ``"<index>.<key>"`` (``"0.W"``, ``"0.b"``, ``"2.W"``, ...) in layer order; they are fresh
    dicts holding the members' own arrays, so in-place writes (:func:`set_flat`) reach the
    members, while assigning a new array to a key of the returned dict does not.

    Parameters
    ----------
    *layers : Layer
        At least one.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.nn import Linear, ReLU, Sequential, Softmax, get_flat
    >>> net = Sequential(Linear(4, 3, seed=1), ReLU(), Linear(3, 2, seed=2), Softmax())
    >>> list(net.params)
    ['0.W', '0.b', '2.W', '2.b']
    >>> P = net.forward(np.arange(8.0).reshape(2, 4))
    >>> np.allclose(P.sum(axis=1), 1.0)
    True
    >>> get_flat(net).shape
    (23,)
    """

    def __init__(self, *layers) -> None:
        # no Layer.__init__: params and grads are the read-only views below
        self._out_shape = None
        if not layers:
            raise ValueError("Sequential needs at least one layer, got none")
        for i, layer in enumerate(layers):
            if not _is_layer_like(layer):
                raise TypeError(
                    f"layers[{i}] must have forward, backward, params and grads, "
                    f"got {type(layer).__name__}"
                )
        self.layers: tuple = tuple(layers)

    @property
    def params(self) -> dict[str, np.ndarray]:  # type: ignore[override]
        return {f"{i}.{k}": v for i, lay in enumerate(self.layers) for k, v in lay.params.items()}

    @property
    def grads(self) -> dict[str, np.ndarray]:  # type: ignore[override]
        return {f"{i}.{k}": v for i, lay in enumerate(self.layers) for k, v in lay.grads.items()}

    def zero_grad(self) -> None:
        for layer in self.layers:
            for g in layer.grads.values():
                g.fill(0.0)

    def forward(self, X) -> np.ndarray:
        """Apply every layer in order; ``(B, d_in) -> (B, d_out)``."""
        for layer in self.layers:
            X = layer.forward(X)
        self._out_shape = np.shape(X)
        return X

    def backward(self, grad_Y) -> np.ndarray:
        """Back-propagate through every layer in reverse; returns shape ``(B, d_in)``."""
        G = _check_grad(grad_Y, self._need_forward())
        for layer in reversed(self.layers):
            G = layer.backward(G)
        return G

    def __len__(self) -> int:
        return len(self.layers)

    def __getitem__(self, index: int):
        return self.layers[index]

    def __repr__(self) -> str:
        inner = ", ".join(repr(layer) for layer in self.layers)
        return f"Sequential({inner})"


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
        For bad names, and for NaN/inf in a JSON file (standard JSON cannot hold them).

    Notes
    -----
    JSON layout: ``{"format": "qdensity-parameters", "version": 1, "arrays": {name:
    {"dtype": ..., "shape": [...], "data": [flat list in C order]}}}``. Floats are written
    with ``repr`` precision, so float64 values round-trip exactly.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> from qdensity.nn import save_parameters, load_parameters
    >>> d = tempfile.mkdtemp()
    >>> save_parameters(os.path.join(d, "p.json"), W=np.eye(2), t=3)
    >>> load_parameters(os.path.join(d, "p.json"))["W"]
    array([[1., 0.],
           [0., 1.]])
    """
    checked = _check_arrays(arrays)
    path = os.fspath(path)
    if str(path).lower().endswith(".json"):
        doc = {"format": _JSON_FORMAT, "version": 1, "arrays": {}}
        for name, arr in checked.items():
            if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
                raise ValueError(f"array {name!r} has NaN or inf, which JSON cannot store")
            doc["arrays"][name] = {
                "dtype": arr.dtype.str,
                "shape": list(arr.shape),
                "data": arr.ravel().tolist(),
            }
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(doc, fh, allow_nan=False)
        return
    # the layout of numpy.savez (one "<name>.npy" member per array, uncompressed), written
    # directly so that no array name can clash with a keyword of numpy.savez
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, arr in checked.items():
            with zf.open(name + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, arr, allow_pickle=False)


def load_parameters(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read arrays written by :func:`save_parameters` (``.npz`` without pickle, or JSON).

    Parameters
    ----------
    path : str or path-like
        A ``*.json`` name is read as JSON, anything else with ``numpy.load(...,
        allow_pickle=False)``.

    Returns
    -------
    dict[str, numpy.ndarray]
        Arrays with their saved dtype and shape (0-d arrays for scalars).

    Raises
    ------
    ValueError
        If the file needs pickle (object arrays or a pickled object), is not an ``.npz``
        archive, or is not a qdensity parameter JSON file.
    """
    path = os.fspath(path)
    if str(path).lower().endswith(".json"):
        with open(path, encoding="utf-8") as fh:
            try:
                doc = json.load(fh)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path!r} is not valid JSON: {exc}") from exc
        if not isinstance(doc, dict) or doc.get("format") != _JSON_FORMAT:
            raise ValueError(f"{path!r} is not a {_JSON_FORMAT!r} JSON file")
        out = {}
        for name, entry in doc.get("arrays", {}).items():
            try:
                dtype = np.dtype(entry["dtype"])
                shape = tuple(int(s) for s in entry["shape"])
                data = entry["data"]
            except (KeyError, TypeError) as exc:
                raise ValueError(f"{path!r}: entry {name!r} lacks dtype/shape/data") from exc
            if dtype.kind not in "biuf":
                raise ValueError(f"{path!r}: entry {name!r} has unsupported dtype {dtype}")
            out[name] = np.asarray(data, dtype=dtype).reshape(shape)
        return out
    try:
        loaded = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, zipfile.BadZipFile) as exc:
        raise ValueError(
            f"cannot load parameters from {path!r} without pickle (allow_pickle=False): {exc}"
        ) from exc
    if not isinstance(loaded, np.lib.npyio.NpzFile):
        raise ValueError(
            f"{path!r} holds a single .npy array, not an .npz archive of named parameters"
        )
    with loaded:
        try:
            return {name: loaded[name] for name in loaded.files}
        except ValueError as exc:
            raise ValueError(
                f"cannot load parameters from {path!r} without pickle (allow_pickle=False): {exc}"
            ) from exc
