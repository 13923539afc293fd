"""Quantum dropout: train a density QNN with the randomised preparation, predict with the
deterministic one (paper "Quantum dropout" and Supp. "Dropout interpretation of density QNNs").

The paper separates the two modes of a density QNN ``rho = sum_k alpha_k U_k rho(x) U_k^dag``
(eq. 1):

* **train** (Fig. 1c, the randomised density QNN): every shot loads ``|x>``, samples one
  sub-unitary ``k ~ alpha`` and runs ``U_k`` only, the others "dropped out". A shot's outcome
  has mean ``f(x) = sum_k alpha_k f_k(x)``; the parameter-shift circuits of a parameter of
  ``U_k`` run only on the shots that sampled ``k``, so the gradient estimate is
  ``sum_k alpha_k d f_k`` in expectation: unbiased, as dropout's per-example sub-network
  gradient is unbiased for the averaged network;
* **eval** (Fig. 1b, the deterministic density QNN): the ancilla register prepares
  ``sum_k sqrt(alpha_k) |k>`` and controls ``U_k``; tracing it out leaves ``rho`` exactly, so one
  evaluation gives ``f(x)`` (dropout's scaled full network at inference).

:class:`RandomisedPreparation` is the train phase for any density model: per data point it
draws the sub-unitary of every shot (``k ~ alpha(x)``), draws each shot's outcome from the exact
law of that circuit's measurement (a Pauli observable ``c P``: ``+-c``; unary probabilities: the
basis state ``e_j``), and estimates the outputs, the angle gradient (each shot runs the gradient
of the sub-unitary it drew) and the mixture gradient (``d f / d alpha_k = f_k``, chained through
the mixture's own ``vjp``), recording every shot in a :class:`~qdensity.execution.ShotLedger`.
:meth:`DensityQNN.randomised_loss_and_grad <qdensity.models.density.DensityQNN.
randomised_loss_and_grad>` uses it with each drawn sub-unitary's exact gradient (the shots'
sub-unitary draw is simulated, the gradient circuits' own shot noise is not);
:class:`QuantumDropout` gives the single-qubit re-uploading model of the paper's overfitting
numerics (Fig. 6b, Supp. J; :class:`~qdensity.models.single_qubit.SingleQubitReuploading`) the
same two phases through the same class, its gradient shots drawn from its parameter-shift
circuits (two per angle, ``+-pi/2``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from qdensity.execution import ShotLedger
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity.validation import as_rng, check_positive_int, check_type

__all__ = ["QuantumDropout", "RandomisedPreparation"]

#: ``gradient(k, shots) -> (N, m, P_k)``: the sum over ``shots[i]`` shots of sub-unitary ``k``
#: of per-shot estimates of ``d f_k(x_i) / d theta_k`` (each unbiased).
GradientShots = Callable[[int, np.ndarray], np.ndarray]


class RandomisedPreparation:
    """The randomised density QNN (Fig. 1c) as a train phase: outputs and gradients from shots.

    Parameters
    ----------
    alpha : numpy.ndarray, shape (N, K)
        Each data point's mixture weights.
    outcome_probabilities : numpy.ndarray, shape (N, K, R)
        The exact law of one shot's outcome for every (data point, sub-unitary).
    outcome_values : numpy.ndarray, shape (R, m)
        What outcome ``r`` reads as (``[[c], [-c]]`` for a Pauli observable ``c P``; the
        identity for unary probabilities).
    shots : int
        Shots per data point for each estimate.
    seed : int or Generator, optional
    ledger : ShotLedger, optional
        Records the shots each sub-unitary's circuits drew (``forward_k{k}``,
        ``{gradient_label}_k{k}``, ``mixture_k{k}``).

    Examples
    --------
    Sub-unitary 0 always reads ``+1``, sub-unitary 1 ``-1``, mixed ``(3/4, 1/4)``: ``f = 1/2``,
    and a shot's value has variance ``1 - f^2 = 3/4``:

    >>> import numpy as np
    >>> from qdensity.execution.engines import ShotLedger
    >>> from qdensity.models.dropout import RandomisedPreparation
    >>> ledger = ShotLedger()
    >>> prep = RandomisedPreparation(np.array([[0.75, 0.25]]), np.array([[[1.0, 0.0], [0.0, 1.0]]]),
    ...                              np.array([[1.0], [-1.0]]), shots=400, seed=0, ledger=ledger)
    >>> f = prep.outputs()
    >>> f.shape, bool(abs(f[0, 0] - 0.5) < 4 * np.sqrt(0.75 / 400)), ledger.total_shots
    ((1, 1), True, 400)
    """

    def __init__(self, alpha: np.ndarray, outcome_probabilities: np.ndarray,
                 outcome_values: np.ndarray, shots: int, *, seed=None,
                 ledger: ShotLedger | None = None):
        self.alpha = np.asarray(alpha, dtype=float)
        probs = np.clip(np.asarray(outcome_probabilities, dtype=float), 0.0, None)
        rest = np.clip(1.0 - probs.sum(axis=-1, keepdims=True), 0.0, None)  # reads as 0
        self.probs = np.concatenate([probs, rest], axis=-1)
        self.probs /= self.probs.sum(axis=-1, keepdims=True)
        values = np.asarray(outcome_values, dtype=float)
        self.values = np.vstack([values, np.zeros((1, values.shape[1]))])
        self.shots = check_positive_int(shots, "shots")
        self.rng = as_rng(seed)
        self.ledger = check_type(ledger, "ledger", ShotLedger, "a ShotLedger", allow_none=True)
        if self.alpha.ndim != 2 or self.probs.shape[:2] != self.alpha.shape:
            raise ValueError(f"alpha must have shape (N, K) and outcome_probabilities "
                             f"(N, K, R); got {self.alpha.shape} and {probs.shape}")

    def draw(self, label: str, circuits: int = 1) -> np.ndarray:
        """Each shot's sub-unitary: counts of shape (N, K) summing to ``shots`` per row."""
        n = self.rng.multinomial(self.shots, self.alpha)
        if self.ledger is not None:
            N = n.shape[0]
            for k in range(n.shape[1]):
                self.ledger.record(f"{label}_k{k}", circuits * N, circuits * int(n[:, k].sum()))
        return n

    def sums(self, n: np.ndarray) -> np.ndarray:
        """Sum of the outcomes (read by ``outcome_values``) of ``n[i, k]`` shots of each
        circuit: shape (N, K, m)."""
        counts = self.rng.multinomial(n, self.probs)  # (N, K, R + 1)
        return counts @ self.values

    def outputs(self) -> np.ndarray:
        """The outputs' estimate ``f_hat``, shape (N, m): mean ``sum_k alpha_k f_k``."""
        return self.sums(self.draw("forward")).sum(axis=1) / self.shots

    def angle_vjp(self, upstream: np.ndarray, gradient: GradientShots,
                  label: str = "gradient", circuits: int = 1) -> list[np.ndarray]:
        """``sum_i upstream_i . d f(x_i) / d theta_k`` per sub-unitary, from fresh shots: each
        shot runs the gradient of the sub-unitary it drew (mean ``alpha_k d f_k``).

        Returns
        -------
        list of numpy.ndarray, each shape (P_k,)
        """
        n = self.draw(label, circuits)
        return [np.einsum("im,imp->p", upstream, gradient(k, n[:, k])) / self.shots
                for k in range(n.shape[1])]

    def alpha_vjp(self, upstream: np.ndarray) -> np.ndarray:
        """``upstream_i . f_k(x_i)`` estimated from fresh shots, shape (N, K): ``d f / d
        alpha_k = f_k``, and ``sum over the shots of k / (shots alpha_k)`` is unbiased for it
        (0 where ``alpha_k = 0``, which no shot draws and no gradient reaches)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            f_k = self.sums(self.draw("mixture")) / (self.shots * self.alpha[:, :, None])
        return np.einsum("im,ikm->ik", upstream, np.nan_to_num(f_k, posinf=0.0, neginf=0.0))


class QuantumDropout:
    """Dropout modes for a single-qubit re-uploading density QNN.

    Parameters
    ----------
    model : SingleQubitReuploading
        ``K >= 1`` sub-unitaries of ``L`` layers, ``alpha = softmax(logits)``; shared, not
        copied (training moves its parameters).
    shots : int
        Shots per data point for each estimate in train mode: the forward estimate, the mixture
        (logit) gradient and each parameter-shift circuit pair draw this many.

    Attributes
    ----------
    training : bool
        True after :meth:`train` (the default), False after :meth:`eval`.

    Examples
    --------
    >>> model = SingleQubitReuploading(2, 3, seed=0)
    >>> drop = QuantumDropout(model, shots=100)
    >>> loss, grad = drop.train().loss_and_grad(np.zeros(4), np.zeros(4), seed=1)
    >>> grad.shape == (model.num_parameters,)
    True
    """

    def __init__(self, model: SingleQubitReuploading, shots: int = 100):
        self.model = check_type(model, "model", SingleQubitReuploading,
                                "a SingleQubitReuploading")
        self.shots = check_positive_int(shots, "shots")
        self.training = True

    def train(self) -> QuantumDropout:
        """Train mode: the randomised preparation (one sub-unitary sampled per shot)."""
        self.training = True
        return self

    def eval(self) -> QuantumDropout:
        """Eval mode: the deterministic preparation (the mixture itself)."""
        self.training = False
        return self

    # ------------------------------------------------------------------ inference
    def predict(self, X, *, shots: int | None = None, seed=None) -> np.ndarray:
        """The deterministic circuit's output ``f(x) = Tr(Z rho(x))`` (Fig. 1b), in either mode.

        Parameters
        ----------
        X : array_like, shape (N,) or (N, 1)
        shots : int, optional
            None: the exact value; else the mean of ``shots`` outcomes of the deterministic
            circuit (its data qubit's reduced state is ``rho(x)``).
        seed : int or Generator, optional

        Returns
        -------
        numpy.ndarray, shape (N,)
        """
        f = self.model.predict(X)
        if shots is None:
            return f
        shots = check_positive_int(shots, "shots")
        plus = as_rng(seed).binomial(shots, (1.0 + np.clip(f, -1, 1)) / 2)
        return (2.0 * plus - shots) / shots

    # ------------------------------------------------------------------ training
    def _shifted(self, X) -> np.ndarray:
        """``f_k`` at every angle of ``U_k`` shifted by ``+-pi/2``: shape (N, K, L, 3, 2)."""
        m = self.model
        K, L = m.num_subunitaries, m.num_layers
        shifts = np.zeros((K, L, 3, 2, L, 3))
        for layer in range(L):
            for slot in range(3):
                shifts[:, layer, slot, 0, layer, slot] = np.pi / 2
                shifts[:, layer, slot, 1, layer, slot] = -np.pi / 2
        theta = m.theta[:, None, None, None, :, :] + shifts  # (K, L, 3, 2, L, 3)
        copies = SingleQubitReuploading(L, K * L * 3 * 2, encoding=m.encoding)
        copies.theta = theta.reshape(K * L * 3 * 2, L, 3)
        return copies.expert_outputs(X).reshape(-1, K, L, 3, 2)

    def loss_and_grad(self, X, y, *, seed=None,
                      ledger: ShotLedger | None = None) -> tuple[float, np.ndarray]:
        """Mean squared error of :meth:`predict` and its gradient w.r.t. ``model.get_params()``.

        In eval mode both are exact (the model's own). In train mode both are estimated from
        shots of the randomised preparation (:class:`RandomisedPreparation`), per data point:

        * forward: ``shots`` shots, each from ``U_k`` with ``k ~ alpha``: ``f_hat``;
        * angles: ``shots`` more, ``k ~ alpha`` per shot; every angle of the sampled ``U_k``
          runs its two parameter-shift circuits on that shot, so ``(B+ - B-) / shots`` (``B+-``
          the shifted circuits' +1 counts) has mean ``alpha_k d f_k / d theta``;
        * logits: ``shots`` more, ``k ~ alpha``: ``(2 P_k - n_k) / (shots alpha_k)`` (``P_k``
          of ``n_k`` shots of ``U_k`` gave +1) has mean ``f_k = d f / d alpha_k``, chained
          through the softmax (``alpha_k (g_k - sum_j alpha_j g_j)``);

        and the gradient is ``(2 / N) sum_i (f_hat_i - y_i) g_hat_i`` with ``f_hat`` from shots
        independent of ``g_hat``, so it is unbiased for the exact gradient; the loss is that of
        ``f_hat``.

        Parameters
        ----------
        X : array_like, shape (N,) or (N, 1)
        y : array_like, shape (N,)
        seed : int or Generator, optional
        ledger : ShotLedger, optional
            Train mode records its shots here (labels ``forward_k{k}``, ``shift_k{k}``,
            ``mixture_k{k}``: the shots each sub-unitary's circuits drew).

        Returns
        -------
        loss : float
        grad : numpy.ndarray, shape (model.num_parameters,)
        """
        if not self.training:
            return self.model.loss_and_grad(X, y)
        m = self.model
        y = np.asarray(y, dtype=float).ravel()
        f_k = m.expert_outputs(X)  # (N, K), refuses bad X
        if y.shape != (f_k.shape[0],):
            raise ValueError(f"y must have shape ({f_k.shape[0]},), got {y.shape}")
        N, K = f_k.shape
        alpha = np.broadcast_to(m.alpha, (N, K))
        plus = (1.0 + np.clip(f_k, -1, 1)) / 2
        prep = RandomisedPreparation(alpha, np.stack([plus, 1.0 - plus], axis=-1),
                                     np.array([[1.0], [-1.0]]), self.shots, seed=seed,
                                     ledger=ledger)
        f_hat = prep.outputs()[:, 0]
        resid = f_hat - y
        loss = float(np.mean(resid**2))
        upstream = (2.0 / N) * resid[:, None]  # (N, 1)
        p_shift = (1.0 + np.clip(self._shifted(X), -1, 1)) / 2  # (N, K, L, 3, 2)
        rng = prep.rng

        def shift_shots(k: int, n: np.ndarray) -> np.ndarray:
            counts = rng.binomial(n[:, None, None, None], p_shift[:, k])  # (N, L, 3, 2)
            return (counts[..., 0] - counts[..., 1]).reshape(N, 1, -1)

        grads = prep.angle_vjp(upstream, shift_shots, "shift", 2 * 3 * m.num_layers)
        grad = np.concatenate(grads)
        if K > 1:
            g = prep.alpha_vjp(upstream).sum(axis=0)  # d loss / d alpha_k, (K,)
            a = m.alpha
            grad = np.concatenate([grad, a * (g - a @ g)])
        return loss, grad


def _outcome_law(model, outputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One shot's outcome law and values for a density model's readout (see
    :class:`RandomisedPreparation`)."""
    if model.readout == "unary_probabilities":
        return outputs, np.eye(outputs.shape[-1])
    obs = model.observable
    coeff = complex(obs.coeffs[0]) if len(obs) == 1 else 0j
    if model.readout != "observable" or len(obs) != 1 or coeff.imag != 0 or coeff.real == 0:
        raise ValueError(
            "the randomised preparation's shots need readout='unary_probabilities' or an "
            f"observable of one Pauli term c P (outcomes +-c); got readout={model.readout!r} "
            f"with observable of {len(obs)} terms")
    c = abs(coeff.real)
    plus = (1.0 + np.clip(outputs[..., 0] / c, -1, 1)) / 2
    return np.stack([plus, 1.0 - plus], axis=-1), np.array([[c], [-c]])


def randomised_loss_and_grad(model, X, y, shots: int, *, seed=None,
                             ledger: ShotLedger | None = None) -> tuple[float, dict]:
    """Squared error of a density model and its gradient, in the model's mode.

    ``model.train()``: from shots of the randomised preparation (Fig. 1c), ``shots`` per data
    point for each of three independent estimates (:class:`RandomisedPreparation`): the
    outputs ``f_hat``; the angle gradient, each shot running the exact gradient of the
    sub-unitary it drew (mean ``sum_k alpha_k d f_k``); the mixture gradient through
    ``d f / d alpha_k = f_k`` and the mixture's ``vjp``. ``f_hat`` is independent of the
    gradient estimates, so the gradient is unbiased for the exact one. ``model.eval()``: the
    exact loss and gradient of the deterministic model ``f = sum_k alpha_k f_k`` (eq. 3).

    Parameters
    ----------
    model : DensityQNN
        ``readout="observable"`` with one Pauli term ``c P``, or
        ``readout="unary_probabilities"``.
    X : array_like, shape (N, d)
    y : array_like, shape (N,) (observable) or (N, n) (unary probabilities)
    shots : int
    seed : int or Generator, optional
    ledger : ShotLedger, optional
        Train mode: the shots each sub-unitary drew (``forward_k{k}``, ``gradient_k{k}``,
        ``mixture_k{k}``; one gradient shot runs ``U_k``'s gradient once).

    Returns
    -------
    loss : float
        ``(1 / N) sum_i ||f_hat_i - y_i||^2``.
    grad : dict
        ``{"theta": (P,), "mixture": (M,)}``, as :meth:`DensityQNN.get_params`.
    """
    from qdensity.models.exact import exact_gradients

    shots = check_positive_int(shots, "shots")
    Xa = model._check_X(X)
    exact = exact_gradients(model, Xa, inputs=False)
    outputs = exact.outputs  # (N, K, m)
    N, K, m = outputs.shape
    yy = np.asarray(y, dtype=float).reshape(N, -1) if np.size(y) == N * m else None
    if yy is None or yy.shape != (N, m):
        raise ValueError(f"y must have shape ({N},) for an observable readout or ({N}, {m}) "
                         f"for unary probabilities, got {np.shape(y)}")
    probs, values = _outcome_law(model, outputs)
    alpha = np.broadcast_to(model.alpha(Xa), (N, K))
    theta = np.zeros(model.num_parameters)
    if model.training:
        prep = RandomisedPreparation(alpha, probs, values, shots, seed=seed, ledger=ledger)
        resid = prep.outputs() - yy
        upstream = (2.0 / N) * resid
        for k, g in enumerate(prep.angle_vjp(
                upstream, lambda k, n: n[:, None, None] * exact.jacobians[k])):
            theta[model.subunitary_parameter_indices(k)] += g
        g_alpha = prep.alpha_vjp(upstream)
    else:
        resid = np.einsum("ik,ikm->im", alpha, outputs) - yy
        upstream = (2.0 / N) * resid
        for k in range(K):
            theta[model.subunitary_parameter_indices(k)] += np.einsum(
                "im,i,imp->p", upstream, alpha[:, k], exact.jacobians[k])
        g_alpha = np.einsum("im,ikm->ik", upstream, outputs)
    mixture = model.mixture.vjp(Xa, g_alpha)
    return float(np.sum(resid**2) / N), {"theta": theta, "mixture": np.asarray(mixture)}
