"""Estimates from circuits whose ancilla register is post-selected (the LCU QNN of Fig. 1a).

A shot *succeeds* when every post-selected qubit reads ``0``; the estimates are read off the
measured bits (never off a dense ``2**m`` row): the success probability ``N_s / N`` with its
never-zero Wilson standard error (:mod:`qdensity.execution.intervals`), and the unary
frequencies of the data register among the successful shots,
``p_j = #(success and data = e_j) / N_s``, whose standard errors are binomial in the ``N_s``
shots that survived. Exact results (probabilities) give the exact conditional probabilities.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from qdensity.execution.intervals import binomial_standard_error
from qdensity.execution.plans import JobResult

__all__ = ["PostselectedUnary", "postselected_unary"]


@dataclass
class PostselectedUnary:
    """Post-selected unary estimates of a batch of circuit rows.

    Attributes
    ----------
    probabilities : numpy.ndarray, shape (rows, n)
        ``P(data = e_j | success)``; rows sum to the unary fraction of the successful shots
        (one without noise). NaN in a row with no successful shot.
    standard_error : numpy.ndarray, shape (rows, n)
        Binomial (Wilson-term) standard errors with the successful shots as sample size;
        zero for exact results, NaN without a success.
    success_probability : numpy.ndarray, shape (rows,)
        Fraction of shots (or exact probability) with every post-selected qubit at ``0``.
    success_standard_error : numpy.ndarray, shape (rows,)
        Wilson standard error over all shots (zero for exact results).
    successes : numpy.ndarray of int, shape (rows,), or None
        Successful shots per row (None for exact results).
    shots : int or None
        Shots per row (None for exact results).

    Examples
    --------
    Exact probabilities over 3 clbits, clbit 0 the post-selected ancilla (outcome ``b_0 + 2 b_1
    + 4 b_2``): the ancilla reads 0 with probability 0.8, and then the data is ``e_0`` (outcome
    2) with probability ``0.6 / 0.8``:

    >>> import numpy as np
    >>> from qdensity.execution.plans import JobResult
    >>> from qdensity.execution.sampler.postselection import postselected_unary
    >>> probs = np.array([[0.0, 0.0, 0.6, 0.1, 0.2, 0.1, 0.0, 0.0]])
    >>> est = postselected_unary(JobResult(probabilities=probs), postselect=[0], data=[1, 2])
    >>> est.success_probability.round(12).tolist(), est.probabilities.round(12).tolist()
    ([0.8], [[0.75, 0.25]])
    >>> est.standard_error.tolist(), est.shots  # exact: no error, no shots
    ([[0.0, 0.0]], None)
    """

    probabilities: np.ndarray
    standard_error: np.ndarray
    success_probability: np.ndarray
    success_standard_error: np.ndarray
    successes: np.ndarray | None
    shots: int | None


def _check_qubits(qubits, num_bits: int, name: str) -> np.ndarray:
    arr = np.asarray(list(qubits), dtype=int)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty sequence of clbit indices, got {qubits!r}")
    if np.any(arr < 0) or np.any(arr >= num_bits):
        raise ValueError(f"{name} must be clbit indices in 0..{num_bits - 1}, got {arr.tolist()}")
    if np.unique(arr).size != arr.size:
        raise ValueError(f"{name} holds repeated clbit indices: {arr.tolist()}")
    return arr


def postselected_unary(result: JobResult, postselect: Sequence[int],
                       data: Sequence[int]) -> PostselectedUnary:
    """Success probability and post-selected unary probabilities of one job's rows.

    Parameters
    ----------
    result : JobResult
        Sampled (``bits``) or exact (``probabilities``); clbit ``j`` measures qubit ``j``.
    postselect : sequence of int
        Clbits that must all read ``0`` (the LCU circuit's ``mix`` register).
    data : sequence of int, length n
        Clbits of the data register in unary order (component ``j`` on ``data[j]``).

    Returns
    -------
    PostselectedUnary

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.execution.plans import JobResult
    >>> bits = np.array([[[0, 1, 0], [1, 1, 0], [0, 0, 1], [0, 1, 0]]], dtype=bool)
    >>> est = postselected_unary(JobResult(bits=bits, shots=4), [0], [1, 2])
    >>> est.success_probability.tolist(), est.probabilities.round(3).tolist()
    ([0.75], [[0.667, 0.333]])
    """
    if not isinstance(result, JobResult):
        raise TypeError(f"result must be a JobResult, got {type(result).__name__}")
    if result.bits is not None:
        bits = np.asarray(result.bits, dtype=bool)
        m = bits.shape[-1]
        sel = _check_qubits(postselect, m, "postselect")
        dat = _check_qubits(data, m, "data")
        if np.intersect1d(sel, dat).size:
            raise ValueError("postselect and data must not share clbits")
        shots = bits.shape[1]
        ok = ~bits[:, :, sel].any(axis=-1)  # (rows, shots)
        d = bits[:, :, dat]
        unary = ok & (d.sum(axis=-1) == 1)
        counts = (d & unary[..., None]).sum(axis=1)  # (rows, n)
        successes = ok.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            probs = counts / successes[:, None]
        se = np.full_like(probs, np.nan)
        hit = successes > 0
        se[hit] = binomial_standard_error(probs[hit], successes[hit, None])
        p_s = successes / shots
        return PostselectedUnary(probs, se, p_s, binomial_standard_error(p_s, shots),
                                 successes.astype(int), int(shots))
    probs_full = np.asarray(result.probabilities, dtype=float)
    m = int(round(np.log2(probs_full.shape[1])))
    sel = _check_qubits(postselect, m, "postselect")
    dat = _check_qubits(data, m, "data")
    if np.intersect1d(sel, dat).size:
        raise ValueError("postselect and data must not share clbits")
    outcomes = np.arange(probs_full.shape[1])
    sel_mask = int(np.sum(1 << sel))
    ok = (outcomes & sel_mask) == 0
    p_s = probs_full[:, ok].sum(axis=1)
    unary = probs_full[:, 1 << dat]  # only bit data[j] set: mix zero, data = e_j
    with np.errstate(invalid="ignore", divide="ignore"):
        probs = np.where(p_s[:, None] > 0, unary / p_s[:, None], np.nan)
    return PostselectedUnary(probs, np.zeros_like(probs), p_s, np.zeros_like(p_s), None, None)
