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
  form the optimisers of :mod:`qdensity.optim` work on), and :func:`save_parameters` /
  :func:`load_parameters` store named arrays as plain ``.npz`` (never pickle) or as JSON;
  they live in :mod:`qdensity.learning.parameters` and are re-exported here.

Shapes: every layer maps a batch ``X`` of shape ``(B, d_in)`` to ``(B, d_out)``; all
arithmetic is float64.
"""

from __future__ import annotations

import abc
import math
from typing import Any

import numpy as np
from scipy.special import erf

from qdensity.learning._checks import _check_batch, _check_grad
from qdensity.learning.parameters import get_flat, load_parameters, save_parameters, set_flat
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
