"""Mixtures: the distribution alpha over sub-unitaries (paper eq. 1, eq. 2, Supp. H).

Three kinds share one interface: ``alpha(X) -> (B, K)``, a flat trainable parameter vector
``params``, ``vjp(X, grad_alpha) -> grad_params`` (the chain rule through the softmax and
the gate, paper "Gradients and training") and ``input_vjp(X, grad_alpha) -> grad_X`` (the
same chain rule to the data, zero unless alpha depends on x).

* :class:`FixedMixture`: alpha on the simplex, not trained (no parameters).
* :class:`SoftmaxMixture`: alpha = softmax(logits), logits trained.
* :class:`GatedMixture`: alpha(x) = softmax(W x + b) ("MoE", eq. 26) or
  softmax(GELU(W x + b)) ("MoE*").
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np
from scipy.special import erf

from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_ROWS,
    MAX_SUBUNITARIES,
    Array,
    Instance,
    Interval,
    Options,
    Seed,
    as_rng,
    check_distribution,
    check_entries,
    check_finite_array,
    check_real_vector,
    validates,
)

__all__ = ["Mixture", "FixedMixture", "SoftmaxMixture", "GatedMixture", "as_mixture", "softmax"]


@validates(z=Array(max_size=MAX_DENSE_ENTRIES))
def softmax(z: np.ndarray) -> np.ndarray:
    """Row-wise softmax, numerically stable. ``z`` shape (..., K).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.models.mixtures import softmax
    >>> softmax(np.array([[0.0, np.log(3.0)], [1000.0, 1000.0]])).round(12).tolist()
    [[0.25, 0.75], [0.5, 0.5]]
    """
    z = z - z.max(axis=-1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


def _softmax_vjp(alpha: np.ndarray, grad_alpha: np.ndarray) -> np.ndarray:
    """Gradient w.r.t. the logits given alpha = softmax(z) and dL/dalpha, both (B, K)."""
    return alpha * (grad_alpha - (grad_alpha * alpha).sum(axis=-1, keepdims=True))


class Mixture(ABC):
    """Base class: a distribution over ``K`` sub-unitaries, possibly data dependent.

    Subclasses set ``num_components`` and implement :meth:`alpha`; a trainable one also
    overrides ``params`` and :meth:`vjp` (and, when data dependent, :meth:`input_vjp`).

    Examples
    --------
    A fixed mixture that always runs the first of two sub-unitaries:

    >>> import numpy as np
    >>> from qdensity.models.mixtures import Mixture
    >>> class FirstOnly(Mixture):
    ...     num_components = 2
    ...     def alpha(self, X=None):
    ...         return np.tile([1.0, 0.0], (1 if X is None else len(X), 1))
    >>> m = FirstOnly()
    >>> m.alpha(np.zeros((3, 1))).tolist(), m.num_params, m.input_vjp(np.zeros((3, 1)), None).shape
    ([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]], 0, (3, 1))
    """

    num_components: int
    data_dependent: bool = False

    @property
    def params(self) -> np.ndarray:
        """Flat trainable parameters, shape (M,)."""
        return np.zeros(0)

    @params.setter
    def params(self, value: np.ndarray) -> None:
        if np.size(value):
            raise ValueError("this mixture has no trainable parameters")

    @property
    def num_params(self) -> int:
        return int(self.params.size)

    @abstractmethod
    def alpha(self, X: np.ndarray | None = None) -> np.ndarray:
        """Mixture weights, shape (B, K) (B = 1 when ``X`` is None and alpha is data-free)."""

    def vjp(self, X: np.ndarray | None, grad_alpha: np.ndarray) -> np.ndarray:
        """``sum_b sum_k grad_alpha[b, k] d alpha[b, k] / d params``, shape (M,)."""
        return np.zeros(0)

    def input_vjp(self, X: np.ndarray, grad_alpha: np.ndarray) -> np.ndarray:
        """``sum_k grad_alpha[b, k] d alpha[b, k] / d X[b, :]``, shape (B, d).

        Zero for a mixture that does not depend on the data.

        Parameters
        ----------
        X : array_like, shape (B, d)
        grad_alpha : array_like, shape (B, K)

        Returns
        -------
        numpy.ndarray, shape (B, d)
        """
        return np.zeros(np.atleast_2d(np.asarray(X, dtype=float)).shape)

    def _batch(self, X: np.ndarray | None) -> int:
        return 1 if X is None else int(np.atleast_2d(X).shape[0])


@validates(alpha=Array(ndim=1, max_size=MAX_SUBUNITARIES))
class FixedMixture(Mixture):
    """A fixed distribution alpha (not trained).

    Parameters
    ----------
    alpha : array_like, shape (K,)
        Non-negative, summing to 1 within 1e-9 (never renormalised).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.models.mixtures import FixedMixture
    >>> FixedMixture([0.25, 0.75]).alpha(np.zeros((2, 3))).tolist()  # one row per data point
    [[0.25, 0.75], [0.25, 0.75]]
    >>> FixedMixture([0.5, 0.6])
    Traceback (most recent call last):
    ValueError: alpha must sum to 1 within 1e-09 (it is not renormalised), got sum 1.1
    """

    def __init__(self, alpha):
        self._alpha = check_distribution(alpha, "alpha")
        self.num_components = self._alpha.size

    def alpha(self, X=None) -> np.ndarray:
        return np.broadcast_to(self._alpha, (self._batch(X), self.num_components)).copy()


@validates(
    num_components=[Interval(int, 1, MAX_SUBUNITARIES), None],
    logits=[Array(ndim=1, max_size=MAX_SUBUNITARIES), None],
    alpha=[Array(ndim=1, max_size=MAX_SUBUNITARIES), None],
)
class SoftmaxMixture(Mixture):
    """Trainable alpha = softmax(logits).

    Parameters
    ----------
    num_components : int, optional
        K; logits start at zero (uniform alpha).
    logits : array_like, shape (K,), optional
    alpha : array_like, shape (K,), optional
        Initial distribution (strictly positive), converted to logits ``log(alpha)``.

    Examples
    --------
    ``d alpha_0 / d z = alpha_0 (e_0 - alpha)``:

    >>> from qdensity.models.mixtures import SoftmaxMixture
    >>> mix = SoftmaxMixture(alpha=[0.25, 0.75])
    >>> mix.alpha().round(12).tolist(), mix.vjp(None, [[1.0, 0.0]]).round(12).tolist()
    ([[0.25, 0.75]], [0.1875, -0.1875])
    >>> SoftmaxMixture(3).alpha().round(4).tolist()  # zero logits: uniform
    [[0.3333, 0.3333, 0.3333]]
    """

    def __init__(self, num_components: int | None = None, *, logits=None, alpha=None):
        given = sum(v is not None for v in (num_components, logits, alpha))
        if given != 1:
            raise ValueError("give exactly one of num_components, logits or alpha")
        if logits is not None:
            self.logits = np.asarray(logits, dtype=float)
        elif alpha is not None:
            a = check_distribution(alpha, "alpha")
            if np.any(a <= 0):
                raise ValueError("alpha must be strictly positive to be expressed as logits")
            self.logits = np.log(a)
        else:
            assert num_components is not None  # the one of the three given
            self.logits = np.zeros(int(num_components))
        self.num_components = self.logits.size

    @property
    def params(self) -> np.ndarray:
        return self.logits.copy()

    @params.setter
    def params(self, value) -> None:
        value = check_real_vector(value, "params")
        if value.size != self.num_components:
            raise ValueError(f"params must have length {self.num_components}, got {value.size}")
        self.logits = value.copy()

    def alpha(self, X=None) -> np.ndarray:
        return np.broadcast_to(softmax(self.logits), (self._batch(X), self.num_components)).copy()

    def vjp(self, X, grad_alpha) -> np.ndarray:
        grad_alpha = np.atleast_2d(grad_alpha)
        a = softmax(self.logits)[None, :]
        return _softmax_vjp(np.broadcast_to(a, grad_alpha.shape), grad_alpha).sum(axis=0)


def _gelu(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact GELU ``z Phi(z)`` and its derivative."""
    cdf = 0.5 * (1.0 + erf(z / math.sqrt(2.0)))
    pdf = np.exp(-0.5 * z**2) / math.sqrt(2.0 * math.pi)
    return z * cdf, cdf + z * pdf


@validates(
    num_features=Interval(int, 1, MAX_ROWS), num_components=Interval(int, 1, MAX_SUBUNITARIES),
    activation=[Options(('gelu',)), None],
    weights=[Array(ndim=2, max_size=MAX_DENSE_ENTRIES), None],
    bias=[Array(ndim=1, max_size=MAX_SUBUNITARIES), None], seed=Seed(),
)
class GatedMixture(Mixture):
    """Data-dependent mixture of experts: ``alpha(x) = softmax(act(W x + b))`` (Supp. H, eq. 26).

    Parameters
    ----------
    num_features : int
        Input dimension d of the gate.
    num_components : int
        K.
    activation : {None, "gelu"}
        None is the paper's "MoE"; "gelu" is "MoE*" (exact erf GELU).
    weights : array_like, shape (K, d), optional
    bias : array_like, shape (K,), optional
    seed : int or Generator, optional
        Initialises ``W`` with N(0, 1/d) entries when ``weights`` is not given; ``b = 0``.

    Examples
    --------
    The weights of each data point, and their input gradient against finite differences:

    >>> import numpy as np
    >>> from qdensity.models.mixtures import GatedMixture
    >>> gate = GatedMixture(2, 3, activation="gelu", seed=0)
    >>> X, g = np.array([[0.3, -0.2]]), np.array([[1.0, 0.0, -1.0]])
    >>> L = lambda X: float(np.sum(g * gate.alpha(X)))
    >>> fd = [(L(X + 1e-6 * e) - L(X - 1e-6 * e)) / 2e-6 for e in np.eye(2)]
    >>> gate.num_params, bool(np.allclose(gate.input_vjp(X, g)[0], fd, atol=1e-8))
    (9, True)
    """

    data_dependent = True

    def __init__(self, num_features: int, num_components: int, *, activation: str | None = None,
                 weights=None, bias=None, seed=None):
        self.num_features, self.num_components = int(num_features), int(num_components)
        self.activation = activation
        shape = (self.num_components, self.num_features)
        check_entries(shape, "the gate's weights (num_components, num_features)")
        if weights is None:
            weights = as_rng(seed).normal(0.0, 1.0 / math.sqrt(self.num_features), shape)
        weights = np.asarray(weights, dtype=float)
        if weights.shape != shape:
            raise ValueError(f"weights must have shape {shape} (num_components, num_features), "
                             f"got {weights.shape}")
        bias = (np.zeros(self.num_components) if bias is None
                else np.asarray(bias, dtype=float))
        if bias.shape != (self.num_components,):
            raise ValueError(f"bias must have shape ({self.num_components},), got {bias.shape}")
        self.weights, self.bias = weights.copy(), bias.copy()

    @property
    def params(self) -> np.ndarray:
        return np.concatenate([self.weights.ravel(), self.bias])

    @params.setter
    def params(self, value) -> None:
        value = check_real_vector(value, "params")
        size = self.weights.size + self.bias.size
        if value.size != size:
            raise ValueError(f"params must have length {size}, got {value.size}")
        self.weights = value[: self.weights.size].reshape(self.weights.shape).copy()
        self.bias = value[self.weights.size:].copy()

    def _check_X(self, X) -> np.ndarray:
        if X is None:
            raise ValueError("a data-dependent mixture needs the data X")
        X = np.atleast_2d(check_finite_array(X, "X"))
        if X.ndim != 2 or X.shape[1] != self.num_features:
            raise ValueError(f"X must have shape (rows, {self.num_features}) ({self.num_features} "
                             f"features), got {X.shape}")
        return X

    def _logits(self, X):
        z = X @ self.weights.T + self.bias
        if self.activation == "gelu":
            return _gelu(z)
        return z, np.ones_like(z)

    def alpha(self, X=None) -> np.ndarray:
        z, _ = self._logits(self._check_X(X))
        return softmax(z)

    def vjp(self, X, grad_alpha) -> np.ndarray:
        X = self._check_X(X)
        z, dz = self._logits(X)
        g = _softmax_vjp(softmax(z), np.atleast_2d(grad_alpha)) * dz
        return np.concatenate([(g.T @ X).ravel(), g.sum(axis=0)])

    def input_vjp(self, X, grad_alpha) -> np.ndarray:
        """``d alpha / d x`` chained: ``(softmax'(z) grad_alpha * act'(z)) W``, shape (B, d)
        (eq. 26 differentiated in ``x``; ``z = W x + b``)."""
        X = self._check_X(X)
        z, dz = self._logits(X)
        grad_alpha = np.atleast_2d(np.asarray(grad_alpha, dtype=float))
        if grad_alpha.shape != z.shape:
            raise ValueError(f"grad_alpha must have shape {z.shape} (B, K), got "
                             f"{grad_alpha.shape}")
        return (_softmax_vjp(softmax(z), grad_alpha) * dz) @ self.weights


@validates(
    mixture=[Instance(Mixture), Array(ndim=1, max_size=MAX_SUBUNITARIES), None],
    num_components=Interval(int, 1, MAX_SUBUNITARIES),
)
def as_mixture(mixture, num_components: int) -> Mixture:
    """A :class:`Mixture` from a Mixture, an alpha vector, or None (uniform, fixed).

    Examples
    --------
    >>> from qdensity.models.mixtures import as_mixture
    >>> as_mixture(None, 4).alpha().tolist()
    [[0.25, 0.25, 0.25, 0.25]]
    >>> as_mixture([0.5, 0.5], 3)
    Traceback (most recent call last):
    ValueError: the mixture has 2 components but there are 3 sub-unitaries
    """
    if mixture is None:
        return FixedMixture(np.full(num_components, 1.0 / num_components))
    if not isinstance(mixture, Mixture):
        mixture = FixedMixture(mixture)
    if mixture.num_components != num_components:
        raise ValueError(
            f"the mixture has {mixture.num_components} components but there are "
            f"{num_components} sub-unitaries"
        )
    return mixture
