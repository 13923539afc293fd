"""Exact, vectorised single-qubit data re-uploading models, vanilla and density (Methods "Data
reuploading", Supp. G.3 eq. 29-30, Supp. J eq. 35-36).

A re-uploading sub-unitary of ``L`` layers maps ``|0>`` to ``U_L V(x) ... U_1 V(x) |0>`` with
``U_l = R_z(θ_l[0]) R_y(θ_l[1]) R_z(θ_l[2])`` (the same gate order and parameter layout as
:func:`qdensity.circuits.ansatze.reuploading`) and outputs ``f_k(x) = <Z>``. The density model
(Supp. J eq. 36) outputs ``g(x) = sum_k alpha_k f_k(x)`` with ``alpha = softmax(logits)``
trainable; ``K = 1`` is the vanilla model (eq. 35).

Encodings: ``"rx"``, ``V(x) = R_x(x)`` (Methods, one rotation per upload, the circuits
module's default) and ``"rx_ry"``, ``V(x) = R_y(x) R_x(x)`` (Supp. J eq. 37's ``R_y(x) R_x(x)``;
two frequencies per upload).

One qubit needs no simulator: the state of every (data point, sub-unitary) pair is a complex
2-vector, every gate a 2 x 2 matrix applied to all pairs at once, and the gradient of the mean
squared error comes from one reverse sweep (``d<Z>/dθ = Im <λ|P|ψ>`` for ``R_P(θ) =
exp(-i θ P / 2)``). Thousands of Adam steps on the paper's 50-layer models take seconds, where
the general circuit machinery would take hours. The oracle tests compare it with Qiskit
statevectors of the re-uploading circuit and with finite differences.
"""

from __future__ import annotations

import numpy as np

from qdensity.models.mixtures import softmax
from qdensity.validation import as_rng, check_entries, check_positive_int

__all__ = ["SingleQubitReuploading", "REUPLOADING_ENCODINGS"]

#: Encoding name -> data rotations applied in circuit order at every upload.
REUPLOADING_ENCODINGS: dict[str, tuple[str, ...]] = {"rx": ("x",), "rx_ry": ("x", "y")}

class SingleQubitReuploading:
    """``K`` single-qubit re-uploading sub-unitaries of ``L`` layers each, mixed by ``alpha``.

    Parameters
    ----------
    num_layers : int
        Uploads per sub-unitary, ``L >= 1`` (the paper's ``L`` for vanilla, ``D`` for density).
    num_subunitaries : int
        ``K >= 1``; ``K = 1`` is the vanilla model (no mixture parameters).
    encoding : {"rx", "rx_ry"}
        See the module docstring.
    seed : int or numpy.random.Generator, optional
        Angles start uniform on ``[0, 2 pi)``; mixture logits start at 0 (uniform ``alpha``).

    Attributes
    ----------
    theta : numpy.ndarray, shape (K, L, 3)
        ``theta[k, l]`` are layer ``l``'s ``(θ^1, θ^2, θ^3)`` of sub-unitary ``k``:
        ``U = R_z(θ^1) R_y(θ^2) R_z(θ^3)`` (``R_z(θ^3)`` acts first).
    logits : numpy.ndarray, shape (K,)

    Examples
    --------
    >>> model = SingleQubitReuploading(3, 2, seed=0)
    >>> model.num_parameters, model.predict(np.zeros((4, 1))).shape
    (20, (4,))
    """

    def __init__(self, num_layers: int, num_subunitaries: int = 1, *, encoding: str = "rx",
                 seed=None):
        self.num_layers = check_positive_int(num_layers, "num_layers")
        self.num_subunitaries = check_positive_int(num_subunitaries, "num_subunitaries")
        check_entries((self.num_subunitaries, self.num_layers, 3),
                      "theta (num_subunitaries, num_layers, 3)")
        if not isinstance(encoding, str) or encoding not in REUPLOADING_ENCODINGS:
            raise ValueError(f"encoding must be one of {sorted(REUPLOADING_ENCODINGS)}, got "
                             f"{encoding!r}")
        self.encoding = encoding
        rng = as_rng(seed)
        self.theta = rng.uniform(0.0, 2 * np.pi, size=(self.num_subunitaries, self.num_layers, 3))
        self.logits = np.zeros(self.num_subunitaries)

    # ------------------------------------------------------------------ parameters
    @property
    def num_parameters(self) -> int:
        """Trainable numbers: ``3 K L`` angles plus ``K`` logits when ``K > 1``."""
        k = self.num_subunitaries
        return 3 * k * self.num_layers + (k if k > 1 else 0)

    @property
    def num_circuit_parameters(self) -> int:
        """Angles in the circuits, ``3 K L`` (the paper's parameter budget)."""
        return 3 * self.num_subunitaries * self.num_layers

    def get_params(self) -> np.ndarray:
        """Flat parameters: angles (``theta.ravel()``) then logits (if ``K > 1``)."""
        flat = self.theta.ravel()
        return np.concatenate([flat, self.logits]) if self.num_subunitaries > 1 else flat.copy()

    def __sklearn_clone__(self) -> SingleQubitReuploading:
        """``sklearn.base.clone``: a deep copy (``get_params`` here is the flat parameter
        vector, not scikit-learn's hyperparameter dictionary)."""
        import copy

        return copy.deepcopy(self)

    def set_params(self, flat) -> None:
        """Inverse of :meth:`get_params`."""
        flat = np.asarray(flat, dtype=float).ravel()
        if flat.size != self.num_parameters:
            raise ValueError(f"params must have length {self.num_parameters}, got {flat.size}")
        n = self.theta.size
        self.theta = flat[:n].reshape(self.theta.shape).copy()
        if self.num_subunitaries > 1:
            self.logits = flat[n:].copy()

    @property
    def alpha(self) -> np.ndarray:
        """Mixture weights ``softmax(logits)``, shape (K,)."""
        return softmax(self.logits[None, :])[0]

    # ------------------------------------------------------------------ evaluation
    def _x(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        if X.ndim == 2 and X.shape[1] == 1:
            X = X[:, 0]
        if X.ndim != 1 or X.size == 0 or not np.all(np.isfinite(X)):
            raise ValueError(f"X must be finite with shape (N,) or (N, 1), N >= 1; got shape "
                             f"{np.shape(X)}")
        return X

    def _sequence(self, x: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray, tuple | None]]:
        """Gates in circuit order: ``(axis, cos(a/2), sin(a/2), (layer, slot) or None)`` with
        half-angle arrays of shape (N, 1) for data gates and (1, K) for trainable ones."""
        cx, sx = np.cos(x / 2)[:, None], np.sin(x / 2)[:, None]
        ct, st = np.cos(self.theta / 2), np.sin(self.theta / 2)
        out: list[tuple[str, np.ndarray, np.ndarray, tuple | None]] = []
        for layer in range(self.num_layers):
            for axis in REUPLOADING_ENCODINGS[self.encoding]:
                out.append((axis, cx, sx, None))
            for slot, axis in ((2, "z"), (1, "y"), (0, "z")):
                out.append((axis, ct[None, :, layer, slot], st[None, :, layer, slot],
                            (layer, slot)))
        return out

    @staticmethod
    def _apply(axis: str, c, s, a, b, inverse: bool = False):
        """``R_axis`` (or its inverse) on the amplitudes ``(a, b)`` of many states."""
        if inverse:
            s = -s
        if axis == "z":
            return a * (c - 1j * s), b * (c + 1j * s)
        if axis == "y":
            return c * a - s * b, s * a + c * b
        return c * a - 1j * s * b, c * b - 1j * s * a

    def _final_states(self, x: np.ndarray, seq=None):
        seq = self._sequence(x) if seq is None else seq
        a = np.ones((x.size, self.num_subunitaries), dtype=complex)
        b = np.zeros_like(a)
        for axis, c, s, _ in seq:
            a, b = self._apply(axis, c, s, a, b)
        return a, b

    def expert_outputs(self, X) -> np.ndarray:
        """``f_k(x) = <Z>`` of every sub-unitary, shape (N, K)."""
        a, b = self._final_states(self._x(X))
        return (a * a.conj() - b * b.conj()).real

    def predict(self, X) -> np.ndarray:
        """``g(x) = sum_k alpha_k f_k(x)``, shape (N,)."""
        return self.expert_outputs(X) @ self.alpha

    def mse(self, X, y) -> float:
        """Mean squared error of :meth:`predict` against ``y``."""
        return float(np.mean((self.predict(X) - np.asarray(y, dtype=float).ravel()) ** 2))

    def loss_and_grad(self, X, y) -> tuple[float, np.ndarray]:
        """Mean squared error and its exact gradient w.r.t. :meth:`get_params`.

        Parameters
        ----------
        X : array_like, shape (N,) or (N, 1)
        y : array_like, shape (N,)

        Returns
        -------
        loss : float
        grad : numpy.ndarray, shape (num_parameters,)
        """
        x = self._x(X)
        y = np.asarray(y, dtype=float).ravel()
        if y.shape != x.shape:
            raise ValueError(f"y must have shape {x.shape}, got {y.shape}")
        seq = self._sequence(x)
        a, b = self._final_states(x, seq)
        f = (a * a.conj() - b * b.conj()).real
        alpha = self.alpha
        resid = f @ alpha - y
        loss = float(np.mean(resid ** 2))
        w = 2.0 * resid[:, None] * alpha[None, :] / x.size          # dL/df, (N, K)
        la, lb = w * a, -w * b                                       # λ = w Z ψ
        g_theta = np.zeros_like(self.theta)
        for axis, c, s, where in reversed(seq):
            if where is not None:  # d f / d θ = Im <λ|P|ψ>, states just after the gate
                if axis == "z":
                    val = la.conj() * a - lb.conj() * b
                else:  # "y": P = [[0, -i], [i, 0]]
                    val = -1j * la.conj() * b + 1j * lb.conj() * a
                g_theta[:, where[0], where[1]] += val.imag.sum(axis=0)
            a, b = self._apply(axis, c, s, a, b, inverse=True)
            la, lb = self._apply(axis, c, s, la, lb, inverse=True)
        grad = g_theta.ravel()
        if self.num_subunitaries > 1:
            g_alpha = 2.0 * resid @ f / x.size
            g_logits = alpha * (g_alpha - g_alpha @ alpha)
            grad = np.concatenate([grad, g_logits])
        return loss, grad
