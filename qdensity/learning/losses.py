"""Losses (value and gradient) and metrics for training density QNNs.

The paper trains every OrthoQNN model with the cross entropy between the model's class
probabilities and the true labels, optionally plus an ``l2`` penalty (Supp.
"Hyperparameters"); regression uses squared error. The numpy estimators need exactly these:
:func:`cross_entropy_with_logits` (stable for any finite logits), :func:`mse`,
:func:`l2_penalty` and :func:`accuracy`. Each loss returns ``(mean loss, gradient with respect
to its first argument)`` so that a training loop can feed the gradient straight into
:meth:`qdensity.learning.nn.Layer.backward`.

Other losses of hybrid models are PyTorch's (:mod:`qdensity.learning.torch`).
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = [
    "mse",
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
    >>> from qdensity.learning.losses import mse
    >>> mse([1.0, 2.0], [0.0, 0.0])
    (2.5, array([1., 2.]))
    """
    p = _real_array(pred, "pred")
    t = _real_array(target, "target")
    _same_shape(p, t, "pred", "target")
    diff = p - t
    return float(np.mean(diff**2)), 2.0 * diff / diff.size


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

    Examples
    --------
    Equal logits over 3 classes: the loss is ``log 3``, whatever the label:

    >>> import numpy as np
    >>> from qdensity.learning.losses import cross_entropy_with_logits
    >>> loss, grad = cross_entropy_with_logits([[0.0, 0.0, 0.0]], [2])
    >>> bool(np.isclose(loss, np.log(3))), grad.round(4).tolist()
    (True, [[0.3333, 0.3333, -0.6667]])
    >>> cross_entropy_with_logits([[1000.0, 0.0]], [1])[0]  # no overflow: exactly 1000
    1000.0
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
        Flat parameter vector (:func:`qdensity.learning.nn.get_flat`).
    strength : float
        Non-negative coefficient.

    Returns
    -------
    loss : float
    grad_params : numpy.ndarray, shape (P,)
        ``2 * strength * params``.

    Examples
    --------
    >>> from qdensity.learning.losses import l2_penalty
    >>> l2_penalty([3.0, 4.0], 0.5)  # 0.5 * 25
    (12.5, array([3., 4.]))
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
    # strength * (2 w), not (2 strength) w: a zero parameter keeps a zero gradient at any
    # finite strength (2 strength may overflow to inf, and inf * 0 is NaN)
    return float(strength * np.dot(w, w)), strength * (2.0 * w)


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
    >>> from qdensity.learning.losses import accuracy
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
