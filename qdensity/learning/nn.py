"""The classical piece a density model needs on its own: a linear read-out (Fig. 11a).

The paper's OrthoQNN outputs a vector ``y`` that an ``n -> classes`` linear layer turns into
logits. The numpy estimators (:mod:`qdensity.learning.estimators`) need exactly that, so it
stays here, with an explicit ``forward`` / ``backward``:

* :class:`Layer` -- the protocol: ``forward(X) -> Y`` caches what ``backward`` needs,
  ``backward(grad_Y) -> grad_X`` stores parameter gradients in ``grads`` (same keys and shapes
  as ``params``) and returns the gradient with respect to the input.
* :class:`Linear` -- ``Y = X W + b``.
* :func:`get_flat` / :func:`set_flat` / :func:`save_parameters` / :func:`load_parameters`,
  re-exported from :mod:`qdensity.learning.parameters`.

Everything else of a hybrid model (the ``784 -> 8`` pre-processing, ReLU, GELU, softmax,
containers) is PyTorch's: put :class:`qdensity.learning.torch.DensityQNNLayer` in a
``torch.nn.Sequential`` (``pip install "qdensity[torch]"``, ``examples/hybrid_mnist.py``).
The mixture-of-experts gate
(Supp. H) is :class:`qdensity.models.mixtures.GatedMixture`.

Shapes: ``(B, d_in) -> (B, d_out)``; all arithmetic is float64.
"""

from __future__ import annotations

import abc
import math

import numpy as np

from qdensity.learning._checks import _check_batch, _check_grad
from qdensity.learning.parameters import get_flat, load_parameters, save_parameters, set_flat
from qdensity.validation import SeedLike, as_rng, check_entries, check_positive_int

__all__ = [
    "Layer",
    "Linear",
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

    Examples
    --------
    A layer ``Y = w X`` with one trainable scalar:

    >>> import numpy as np
    >>> from qdensity.learning.nn import Layer
    >>> class Scale(Layer):
    ...     def __init__(self):
    ...         super().__init__()
    ...         self.params, self.grads = {"w": np.array([2.0])}, {"w": np.zeros(1)}
    ...     def forward(self, X):
    ...         self.last_X = np.asarray(X, dtype=float)  # what backward needs
    ...         return self.params["w"] * self.last_X
    ...     def backward(self, grad_Y):
    ...         self.grads["w"][:] = np.sum(grad_Y * self.last_X)
    ...         return self.params["w"] * grad_Y
    >>> layer = Scale()
    >>> layer([[1.0, 2.0]]).tolist(), layer.backward(np.ones((1, 2))).tolist()
    ([[2.0, 4.0]], [[2.0, 2.0]])
    >>> layer.grads["w"].tolist(), layer.num_parameters
    ([3.0], 1)
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
    >>> from qdensity.learning.nn import Linear
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
        check_entries((self.in_features, self.out_features), "W (in_features, out_features)")
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
        assert self._X is not None  # kept by forward
        self.grads["W"][...] = self._X.T @ G
        if self.bias:
            self.grads["b"][...] = G.sum(axis=0)
        return G @ self.params["W"].T

    def __repr__(self) -> str:
        return f"Linear({self.in_features}, {self.out_features}, bias={self.bias})"
