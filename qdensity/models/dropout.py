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

:class:`QuantumDropout` gives the single-qubit re-uploading density model of the paper's
overfitting numerics (Fig. 6b, Supp. J; :class:`~qdensity.models.single_qubit.
SingleQubitReuploading`) these two modes. Its shots follow the exact law of each circuit's
outcomes (a single-qubit ``<Z>`` measurement is a ``+-1`` coin with ``P(+1) = (1 + <Z>) / 2``),
so training costs what a device would pay, recorded in a :class:`~qdensity.execution.ShotLedger`.
"""

from __future__ import annotations

import numpy as np

from qdensity.execution import ShotLedger
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity.validation import as_rng, check_positive_int, check_type

__all__ = ["QuantumDropout"]


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
        shots of the randomised preparation, per data point:

        * forward: ``shots`` shots, each from ``U_k`` with ``k ~ alpha``: ``f_hat``;
        * angles: ``shots`` more, ``k ~ alpha`` per shot; every angle of the sampled ``U_k``
          runs its two parameter-shift circuits on that shot, so ``(B+ - B-) / shots`` (``B+-``
          the shifted circuits' +1 counts) has mean ``alpha_k d f_k / d theta``;
        * logits: ``shots`` more, ``k ~ alpha``: ``(2 P_k - n_k) / shots - alpha_k f_hat'``
          (``P_k`` of ``n_k`` shots of ``U_k`` gave +1) has mean
          ``alpha_k (f_k - f) = d f / d logit_k``;

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
        check_type(ledger, "ledger", ShotLedger, "a ShotLedger", allow_none=True)
        m, rng, S = self.model, as_rng(seed), self.shots
        y = np.asarray(y, dtype=float).ravel()
        f_k = m.expert_outputs(X)  # (N, K), refuses bad X
        if y.shape != (f_k.shape[0],):
            raise ValueError(f"y must have shape ({f_k.shape[0]},), got {y.shape}")
        N, K = f_k.shape
        alpha = m.alpha
        p_k = (1.0 + np.clip(f_k, -1, 1)) / 2

        def draw(label: str):
            n = rng.multinomial(S, alpha, size=N)  # (N, K) shots per sub-unitary
            plus = rng.binomial(n, p_k)
            if ledger is not None:
                for k in range(K):
                    ledger.record(f"{label}_k{k}", N, int(n[:, k].sum()))
            return n, plus

        n_f, plus_f = draw("forward")
        f_hat = (2.0 * plus_f - n_f).sum(axis=1) / S
        resid = f_hat - y
        loss = float(np.mean(resid**2))

        n_g = rng.multinomial(S, alpha, size=N)  # (N, K)
        shifted = (1.0 + np.clip(self._shifted(X), -1, 1)) / 2  # (N, K, L, 3, 2)
        counts = rng.binomial(n_g[:, :, None, None, None], shifted)
        g_theta = (counts[..., 0] - counts[..., 1]) / S  # (N, K, L, 3): alpha_k d f_k, est.
        if ledger is not None:
            for k in range(K):
                ledger.record(f"shift_k{k}", 2 * 3 * m.num_layers * N,
                              int(2 * 3 * m.num_layers * n_g[:, k].sum()))
        grad = (2.0 / N) * np.einsum("i,iklj->klj", resid, g_theta).ravel()
        if K > 1:
            n_m, plus_m = draw("mixture")
            f_hat2 = (2.0 * plus_m - n_m).sum(axis=1) / S
            g_logit = (2.0 * plus_m - n_m) / S - alpha[None, :] * f_hat2[:, None]  # (N, K)
            grad = np.concatenate([grad, (2.0 / N) * resid @ g_logit])
        return loss, grad
