"""Losses (value and gradient) and metrics for training density QNNs.

The paper trains every OrthoQNN model with the cross entropy between the model's class
probabilities and the true labels, optionally plus an ``l2`` penalty (Supp.
"Hyperparameters"); the equivariant and data re-uploading experiments use binary and
regression losses. Each loss here returns ``(mean loss, gradient with respect to its first
argument)`` so that a training loop can feed the gradient straight into
:meth:`qdensity.nn.Layer.backward`.

Nothing is clipped: a probability of exactly 0 or 1 where the loss needs a logarithm is
refused with a ``ValueError`` (use the ``*_with_logits`` variants, which are stable for any
finite logits).
"""

from __future__ import annotations

import numbers

import numpy as np

from qdensity.validation import check_rows_sum_to_one

__all__ = [
    "mse",
    "binary_cross_entropy",
    "binary_cross_entropy_with_logits",
    "cross_entropy",
    "cross_entropy_with_logits",
    "l2_penalty",
    "accuracy",
]


# --------------------------------------------------------------------------------------------
# input checks


def _real_array(x, name: str) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {x!r}") from exc
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def _same_shape(a: np.ndarray, b: np.ndarray, name_a: str, name_b: str) -> None:
    if a.shape != b.shape:
        raise ValueError(
            f"{name_a} and {name_b} must have the same shape, got {a.shape} and {b.shape}"
        )


def _labels(labels, num_rows: int, num_classes: int | None, name: str = "labels") -> np.ndarray:
    arr = np.asarray(labels)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integers (class indices), got dtype {arr.dtype}")
    if arr.shape != (num_rows,):
        raise ValueError(f"{name} must have shape ({num_rows},) (one per row), got {arr.shape}")
    if num_classes is not None and arr.size and (arr.min() < 0 or arr.max() >= num_classes):
        bad = arr[(arr < 0) | (arr >= num_classes)]
        raise ValueError(
            f"{name} must lie in 0..{num_classes - 1} ({num_classes} classes), "
            f"got {bad[:10].tolist()}"
        )
    return arr.astype(np.intp)


def _scores_2d(x, name: str) -> np.ndarray:
    arr = _real_array(x, name)
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (batch, classes), got {arr.shape}")
    return arr


# --------------------------------------------------------------------------------------------
# losses


def mse(pred, target) -> tuple[float, np.ndarray]:
    """Mean squared error over all entries, ``mean((pred - target)^2)``.

    Parameters
    ----------
    pred : array_like, any shape
    target : array_like, same shape as ``pred``

    Returns
    -------
    loss : float
    grad_pred : numpy.ndarray, shape of ``pred``
        ``2 (pred - target) / N`` with ``N = pred.size``.

    Examples
    --------
    >>> from qdensity.losses import mse
    >>> mse([1.0, 2.0], [0.0, 0.0])
    (2.5, array([1., 2.]))
    """
    p = _real_array(pred, "pred")
    t = _real_array(target, "target")
    _same_shape(p, t, "pred", "target")
    diff = p - t
    return float(np.mean(diff**2)), 2.0 * diff / diff.size


def binary_cross_entropy(p, y) -> tuple[float, np.ndarray]:
    """Mean binary cross entropy ``-mean(y log p + (1 - y) log(1 - p))`` on probabilities.

    Parameters
    ----------
    p : array_like, any shape
        Predicted probabilities of class 1, strictly inside ``(0, 1)`` (no clipping).
    y : array_like, same shape as ``p``
        Targets in ``[0, 1]`` (hard labels 0/1 or soft targets).

    Returns
    -------
    loss : float
    grad_p : numpy.ndarray, shape of ``p``
        ``(p - y) / (p (1 - p) N)``.
    """
    p_arr = _real_array(p, "p")
    y_arr = _real_array(y, "y")
    _same_shape(p_arr, y_arr, "p", "y")
    if np.any(p_arr <= 0) or np.any(p_arr >= 1):
        raise ValueError(
            "p must lie strictly inside (0, 1) (it is not clipped; use "
            f"binary_cross_entropy_with_logits for saturated outputs), got range "
            f"[{p_arr.min()!r}, {p_arr.max()!r}]"
        )
    if np.any(y_arr < 0) or np.any(y_arr > 1):
        raise ValueError(f"y must lie in [0, 1], got range [{y_arr.min()!r}, {y_arr.max()!r}]")
    n = p_arr.size
    loss = -np.mean(y_arr * np.log(p_arr) + (1.0 - y_arr) * np.log1p(-p_arr))
    grad = (p_arr - y_arr) / (p_arr * (1.0 - p_arr) * n)
    return float(loss), grad


def binary_cross_entropy_with_logits(z, y) -> tuple[float, np.ndarray]:
    """Binary cross entropy of ``sigmoid(z)``, computed stably from the logits ``z``.

    Uses ``max(z, 0) - z y + log(1 + exp(-|z|))``, exact for every finite ``z``.

    Parameters
    ----------
    z : array_like, any shape
        Logits.
    y : array_like, same shape as ``z``
        Targets in ``[0, 1]``.

    Returns
    -------
    loss : float
    grad_z : numpy.ndarray, shape of ``z``
        ``(sigmoid(z) - y) / N``.
    """
    z_arr = _real_array(z, "z")
    y_arr = _real_array(y, "y")
    _same_shape(z_arr, y_arr, "z", "y")
    if np.any(y_arr < 0) or np.any(y_arr > 1):
        raise ValueError(f"y must lie in [0, 1], got range [{y_arr.min()!r}, {y_arr.max()!r}]")
    n = z_arr.size
    loss = np.mean(np.maximum(z_arr, 0.0) - z_arr * y_arr + np.log1p(np.exp(-np.abs(z_arr))))
    # sigmoid without overflow: exp of a non-positive number only
    e = np.exp(-np.abs(z_arr))
    sig = np.where(z_arr >= 0, 1.0 / (1.0 + e), e / (1.0 + e))
    return float(loss), (sig - y_arr) / n


def cross_entropy(probs, labels, *, atol: float = 1e-6) -> tuple[float, np.ndarray]:
    """Categorical cross entropy ``-mean_i log probs[i, labels[i]]`` on probability rows.

    The loss of the paper's OrthoQNN experiments (Fig. 11, Supp. "Hyperparameters") after the
    post-processing ``softmax``.

    Parameters
    ----------
    probs : array_like, shape (B, C)
        Rows on the probability simplex: entries in ``[0, 1]``, each row summing to 1 within
        ``atol`` (never renormalised). The probability of each true class must be > 0.
    labels : array_like of int, shape (B,)
        Class indices in ``0 .. C-1``.
    atol : float
        Tolerance on the row sums.

    Returns
    -------
    loss : float
    grad_probs : numpy.ndarray, shape (B, C)
        ``-1 / (B probs[i, labels[i]])`` at the true classes, 0 elsewhere (each entry treated
        as a free variable; a preceding :class:`qdensity.nn.Softmax` handles the simplex).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.losses import cross_entropy
    >>> loss, grad = cross_entropy([[0.5, 0.5], [0.25, 0.75]], [0, 1])
    >>> bool(np.isclose(loss, -(np.log(0.5) + np.log(0.75)) / 2))
    True
    """
    P = _scores_2d(probs, "probs")
    B, C = P.shape
    y = _labels(labels, B, C)
    if np.any(P < 0) or np.any(P > 1):
        raise ValueError(f"probs must lie in [0, 1], got range [{P.min()!r}, {P.max()!r}]")
    check_rows_sum_to_one(P, "probs", atol=atol)
    picked = P[np.arange(B), y]
    if np.any(picked <= 0):
        rows = np.flatnonzero(picked <= 0)
        raise ValueError(
            f"probs of the true class is 0 in rows {rows[:10].tolist()} (infinite loss; it is "
            "not clipped, use cross_entropy_with_logits on the logits instead)"
        )
    grad = np.zeros_like(P)
    grad[np.arange(B), y] = -1.0 / (B * picked)
    return float(-np.mean(np.log(picked))), grad


def cross_entropy_with_logits(logits, labels) -> tuple[float, np.ndarray]:
    """Categorical cross entropy of ``softmax(logits)``, stable through log-softmax.

    ``loss = mean_i (logsumexp(z_i) - z_i[labels_i])``, exact for every finite logit.

    Parameters
    ----------
    logits : array_like, shape (B, C)
    labels : array_like of int, shape (B,)
        Class indices in ``0 .. C-1``.

    Returns
    -------
    loss : float
    grad_logits : numpy.ndarray, shape (B, C)
        ``(softmax(z) - onehot(labels)) / B``.
    """
    Z = _scores_2d(logits, "logits")
    B, C = Z.shape
    y = _labels(labels, B, C)
    shifted = Z - Z.max(axis=1, keepdims=True)
    lse = np.log(np.sum(np.exp(shifted), axis=1))
    log_probs = shifted - lse[:, None]
    loss = -np.mean(log_probs[np.arange(B), y])
    grad = np.exp(log_probs)
    grad[np.arange(B), y] -= 1.0
    return float(loss), grad / B


def l2_penalty(params, strength: float) -> tuple[float, np.ndarray]:
    """The ``l2`` regularisation ``strength * ||params||^2`` (Supp. "Hyperparameters").

    Parameters
    ----------
    params : array_like, shape (P,)
        Flat parameter vector (:func:`qdensity.nn.get_flat`).
    strength : float
        Non-negative coefficient.

    Returns
    -------
    loss : float
    grad_params : numpy.ndarray, shape (P,)
        ``2 * strength * params``.
    """
    w = np.asarray(params, dtype=float)
    if w.ndim != 1:
        raise ValueError(f"params must be a flat vector, got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError("params must be finite (no NaN or inf)")
    if isinstance(strength, bool) or not isinstance(strength, numbers.Real):
        raise TypeError(f"strength must be a real number, got {strength!r}")
    if not np.isfinite(strength) or strength < 0:
        raise ValueError(f"strength must be finite and >= 0, got {strength!r}")
    return float(strength * np.dot(w, w)), 2.0 * strength * w


# --------------------------------------------------------------------------------------------
# metrics


def accuracy(pred, labels, *, threshold: float | None = None) -> float:
    """Fraction of correct predictions.

    Parameters
    ----------
    pred : array_like
        One of: integer predicted labels, shape ``(B,)``; scores or probabilities, shape
        ``(B, C)`` with ``C >= 2`` (the row's argmax is the prediction); or, with
        ``threshold``, binary scores of shape ``(B,)`` or ``(B, 1)`` (predicted class
        ``1`` where ``score > threshold``).
    labels : array_like of int, shape (B,)
    threshold : float, optional
        Decision threshold for binary scores (0.5 for probabilities, 0 for logits).

    Returns
    -------
    float
        In ``[0, 1]``.

    Examples
    --------
    >>> from qdensity.losses import accuracy
    >>> accuracy([[0.9, 0.1], [0.2, 0.8], [0.6, 0.4]], [0, 1, 1])
    0.6666666666666666
    >>> accuracy([0.3, 0.7], [0, 1], threshold=0.5)
    1.0
    """
    arr = np.asarray(pred)
    if threshold is not None:
        if isinstance(threshold, bool) or not isinstance(threshold, numbers.Real):
            raise TypeError(f"threshold must be a real number, got {threshold!r}")
        scores = _real_array(arr, "pred")
        if scores.ndim == 2 and scores.shape[1] == 1:
            scores = scores[:, 0]
        if scores.ndim != 1:
            raise ValueError(
                f"with a threshold, pred must have shape (batch,) or (batch, 1), got {arr.shape}"
            )
        predicted = (scores > threshold).astype(np.intp)
        y = _labels(labels, scores.shape[0], None)
    elif arr.ndim == 1:
        if arr.dtype.kind not in "iu":
            raise TypeError(
                "1-d pred must be integer labels; for binary scores pass threshold=..., "
                f"got dtype {arr.dtype}"
            )
        predicted = arr
        y = _labels(labels, arr.shape[0], None)
    elif arr.ndim == 2:
        scores = _scores_2d(arr, "pred")
        if scores.shape[1] < 2:
            raise ValueError(
                f"pred scores need >= 2 columns for an argmax, got shape {scores.shape}; "
                "for a single binary score column pass threshold=..."
            )
        predicted = np.argmax(scores, axis=1)
        y = _labels(labels, scores.shape[0], scores.shape[1])
    else:
        raise ValueError(f"pred must have shape (batch,) or (batch, classes), got {arr.shape}")
    if y.size == 0:
        raise ValueError("labels must not be empty")
    return float(np.mean(predicted == y))
