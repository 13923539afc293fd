"""Training loops shared by the LCU experiments (``lcu-vs-single``, ``mixing-lemma``).

Minibatch Adam (or SGD, RMSprop: the paper's optimiser choices) on one flat parameter vector
(the sub-unitaries' angles, or the mixture's parameters alone, as Supp. C trains them), with an
optional l2 penalty, and the exact unary engine's reverse pass
(:meth:`qdensity.models.lcu.LCUQNN.vjp`, :func:`qdensity.execution.unary.vjp`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from qdensity.execution.unary import forward
from qdensity.learning.optim import SGD, Adam, RMSprop
from qdensity.models.lcu import LCUQNN

__all__ = ["fit_epochs", "nll_grad", "orthogonal_matrix", "accuracy", "check_settings",
           "OPTIMISERS"]

#: The optimisers of the paper's search space (hyperparameters appendix), by name.
OPTIMISERS = {"adam": Adam, "sgd": SGD, "rmsprop": RMSprop}


def check_settings(config: dict, positive_ints=(), positive_floats=(), minimum: dict | None = None
                   ) -> None:
    """Refuse bad settings with a ValueError naming the setting."""
    minimum = minimum or {}
    for key in positive_ints:
        v = config[key]
        low = minimum.get(key, 1)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ValueError(f"setting {key!r} must be an int >= {low}, got {v!r}")
    for key in positive_floats:
        v = config[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
            raise ValueError(f"setting {key!r} must be a positive number, got {v!r}")


def orthogonal_matrix(circuit, theta) -> np.ndarray:
    """The ``n x n`` orthogonal matrix ``O`` of an RBS/FBS circuit on unary states (``y = O x``).

    Parameters
    ----------
    circuit : QuantumCircuit
        Hamming-weight-preserving, ``n`` qubits.
    theta : array_like, shape (P,)

    Returns
    -------
    numpy.ndarray, shape (n, n)
    """
    n = circuit.num_qubits
    return forward(circuit, np.eye(n), np.asarray(theta, dtype=float)).T


def nll_grad(P: np.ndarray, y: np.ndarray, floor: float = 1e-12) -> tuple[float, np.ndarray]:
    """Mean negative log-likelihood of the labels under the unary probabilities ``P``.

    Returns
    -------
    loss : float
    grad_P : numpy.ndarray, shape P.shape
    """
    B = P.shape[0]
    py = np.maximum(P[np.arange(B), y], floor)
    grad = np.zeros_like(P)
    grad[np.arange(B), y] = -1.0 / (B * py)
    return float(-np.mean(np.log(py))), grad


def accuracy(P: np.ndarray, y: np.ndarray) -> float:
    """Fraction of rows whose largest unary probability is the label."""
    return float(np.mean(np.argmax(P, axis=1) == y))


def fit_epochs(model: LCUQNN, X: np.ndarray, y: np.ndarray, *, epochs: int, batch_size: int,
               learning_rate: float, train: str, rng: np.random.Generator,
               after_epoch: Callable[[int], None] | None = None, optimizer: str = "adam",
               l2: float = 0.0) -> None:
    """Minibatch gradient descent on the classification NLL of ``model.predict``.

    Parameters
    ----------
    model : LCUQNN
    X, y : numpy.ndarray
        Inputs (B, n) and labels in ``0..n-1``.
    epochs, batch_size : int
    learning_rate : float
    train : {"theta", "mixture"}
        Which parameters move (Supp. C trains the sub-unitaries first, then only the mixture).
    rng : numpy.random.Generator
        Shuffles the batches.
    after_epoch : callable, optional
        Called with the epoch number (1-based) after each epoch.
    optimizer : {"adam", "sgd", "rmsprop"}
    l2 : float
        Weight of ``l2 / 2 * ||w||^2`` added to the loss of the trained parameters ``w``
        (torch's ``weight_decay``).
    """
    if optimizer not in OPTIMISERS:
        raise ValueError(f"optimizer must be one of {sorted(OPTIMISERS)}, got {optimizer!r}")
    if isinstance(l2, bool) or not isinstance(l2, (int, float)) or not l2 >= 0:
        raise ValueError(f"l2 must be a non-negative number, got {l2!r}")
    opt = OPTIMISERS[optimizer](lr=learning_rate)
    for epoch in range(1, epochs + 1):
        order = rng.permutation(len(X))
        for start in range(0, len(X), batch_size):
            idx = order[start:start + batch_size]
            _, dP = nll_grad(model.predict(X[idx]), y[idx])
            g_theta, g_mix = model.vjp(X[idx], dP, wrt=train)
            w = model.theta if train == "theta" else model.mixture.params
            g = g_theta if train == "theta" else g_mix
            if l2:
                g = g + l2 * w
            if train == "theta":
                model.theta = opt.step(w, g)
            else:
                model.mixture.params = opt.step(w, g)
        if after_epoch is not None:
            after_epoch(epoch)
