"""What an engine returns for one job: :class:`JobResult` (exact probabilities, or the
measured bits of every shot with, for a corrected run, per-shot weights), and the frequencies
read off it (:func:`bits_to_probabilities`, :func:`unary_frequencies`)."""

from __future__ import annotations

from typing import Literal, overload

import numpy as np

from qdensity.execution.intervals import binomial_standard_error, shot_mean
from qdensity.validation import MAX_DENSE_QUBITS, MAX_SHOTS, Array, Instance, Interval, validates

__all__ = ["JobResult", "bits_to_probabilities", "unary_frequencies"]


@validates(
    probabilities=[Array(ndim=(1, 2), min_size=0), None],
    shots=[Interval(int, 1, MAX_SHOTS), None],
    job=[Instance('qdensity.execution.plans:CircuitJob'), None],
    # a BitArray or DeferredSamples: the packed (or not yet drawn) shots a PackedJobResult
    # (the sampler engine's) unpacks on read
    bits=[Array(ndim=3, dtype='bool', min_size=0), Instance('qiskit.primitives:BitArray'),
          Instance('qdensity.execution.samplers._hamming_draw:DeferredSamples'), None],
    weights=[Array(ndim=2, min_size=0), None], effective_shots=[Array(ndim=1, min_size=0), None],
    readout=[Instance(list), None],
)
class JobResult:
    """Outcomes of one job: exact probabilities, or the sampled bits.

    Attributes
    ----------
    probabilities : numpy.ndarray, shape (rows, 2**num_clbits)
        Exact probabilities, or empirical frequencies ``counts / shots`` built from ``bits``
        on first access -- only up to :data:`~qdensity.validation.MAX_DENSE_QUBITS`
        clbits (a ``ValueError`` above: estimate from ``bits``).
    shots : int or None
        Shots per row that produced the frequencies (``None`` when exact).
    job : CircuitJob
    bits : numpy.ndarray of bool, shape (rows, shots, num_clbits), or None
        The measured bits of every shot (clbit ``j`` = column ``j``) when sampled; estimates
        read parities and observed outcomes from them with memory ``O(rows x shots)``.
    weights : numpy.ndarray, shape (rows, shots), or None
        Per-shot weights of a corrected run (readout mitigation, post-selection: see
        :class:`~qdensity.execution.engines.SamplerEngine`), mean 1 per row: every estimate
        is the weighted mean ``mean_s w_s f(b_s)``. None: raw shots.
    effective_shots : numpy.ndarray, shape (rows,), or None
        With ``weights``: ``N_eff = kappa N / M`` per row (kept fraction ``kappa``,
        mitigation overhead ``M``), the shots behind the standard errors of a post-selected
        run; a mitigated row's errors come from ``readout`` (``N_eff`` only sizes the
        ``R^2 / (4 N_eff^2)`` floor, and serves rows without a linearisation).
    readout : list or None
        With readout mitigation, one linearisation per row (or None for a row with too many
        observed outcomes): the delta-method variance of the row's corrected estimates over
        its shots and the calibration's
        (:func:`~qdensity.execution.intervals.shot_mean`'s ``linearisations``).

    Examples
    --------
    Two rows of three shots on two clbits (clbit ``j`` is column ``j``; outcome ``b_0 + 2 b_1``):

    >>> import numpy as np
    >>> from qdensity.execution.plans import JobResult
    >>> bits = np.array([[[0, 0], [1, 0], [1, 0]], [[1, 1], [1, 1], [0, 1]]], dtype=bool)
    >>> result = JobResult(bits=bits, shots=3)
    >>> result.bits_shape, (result.probabilities * 3).round(12).tolist()
    ((2, 3, 2), [[1.0, 2.0, 0.0, 0.0], [0.0, 0.0, 1.0, 2.0]])
    >>> JobResult()
    Traceback (most recent call last):
    ValueError: JobResult needs probabilities or bits
    """

    def __init__(self, probabilities=None, shots: int | None = None, job=None, bits=None,
                 weights=None, effective_shots=None, readout=None):
        if probabilities is None and bits is None:
            raise ValueError("JobResult needs probabilities or bits")
        if (weights is None) != (effective_shots is None):
            raise ValueError("JobResult needs weights and effective_shots together")
        self._probabilities = probabilities
        self.shots = shots
        self.job = job
        self.bits = bits
        self.weights = weights
        self.effective_shots = effective_shots
        self.readout = readout

    @property
    def probabilities(self) -> np.ndarray:
        if self._probabilities is None:
            self._probabilities = bits_to_probabilities(self.bits, self.weights)
        return self._probabilities

    @property
    def sample_size(self) -> int | np.ndarray | None:
        """Shots behind a standard error: ``shots``, or ``effective_shots[:, None]`` of a
        corrected run (broadcasts against ``(rows, k)`` estimates)."""
        if self.weights is not None:
            return np.asarray(self.effective_shots)[:, None]
        return self.shots

    @property
    def has_bits(self) -> bool:
        """Whether the result holds sampled shots (checked without reading ``bits``)."""
        return self.bits is not None

    @property
    def bits_shape(self) -> tuple[int, int, int]:
        """``(rows, shots, num_clbits)`` of the sampled ``bits`` (read without unpacking)."""
        if self.bits is None:
            raise ValueError("bits_shape needs sampled bits; this result holds probabilities")
        rows, shots, m = np.shape(self.bits)
        return int(rows), int(shots), int(m)

    def set_clbits(self) -> tuple[np.ndarray, np.ndarray]:
        """The clbits read as 1 in every shot, as sparse indices (sampled results only).

        Estimates of Hamming-weight circuits read these instead of the dense ``bits``: a shot
        sets a few of its ``num_clbits`` bits, so the work is ``O(rows x shots)`` (plus a scan
        of the packed bytes of a :class:`~qdensity.execution.sampler.engine.SamplerEngine`
        result), not ``O(rows x shots x num_clbits)``.

        Returns
        -------
        (numpy.ndarray, numpy.ndarray), int64, each shape (nnz,)
            ``shot = row * shots + s`` (ascending) and the clbit set in it.
        """
        if self.bits is None:
            raise ValueError("set_clbits needs sampled bits; this result holds probabilities")
        b = np.asarray(self.bits)
        shot, clbit = np.nonzero(b.reshape(b.shape[0] * b.shape[1], b.shape[2]))
        return shot.astype(np.int64), clbit.astype(np.int64)

    def __repr__(self) -> str:
        what = "bits" if self._probabilities is None else "probabilities"
        return f"JobResult({what}, shots={self.shots}, job={self.job!r})"


def bits_to_probabilities(bits: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Empirical frequencies ``(rows, 2**m)`` of sampled bits ``(rows, shots, m)`` (weighted by
    per-shot ``weights`` ``(rows, shots)`` of mean 1 when given: a corrected distribution).

    Raises
    ------
    ValueError
        Above :data:`~qdensity.validation.MAX_DENSE_QUBITS` bits (the dense row would
        need ``2**m`` entries): estimate from the bits instead.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.execution.plans import bits_to_probabilities
    >>> bits = np.array([[[1, 0], [1, 0], [0, 1], [1, 1]]], dtype=bool)  # outcomes 1, 1, 2, 3
    >>> bits_to_probabilities(bits).tolist()
    [[0.0, 0.5, 0.25, 0.25]]
    >>> bits_to_probabilities(bits, weights=np.array([[1.0, 1.0, 2.0, 0.0]])).tolist()
    [[0.0, 0.5, 0.5, 0.0]]
    """
    rows, shots, m = bits.shape
    if m > MAX_DENSE_QUBITS:
        raise ValueError(
            f"dense outcome frequencies over {m} clbits need 2**{m} entries per row; above "
            f"MAX_DENSE_QUBITS = {MAX_DENSE_QUBITS} estimate from the sampled bits "
            "(JobResult.bits: parities, observed outcomes)"
        )
    ints = bits.astype(np.int64) @ (1 << np.arange(m, dtype=np.int64))
    dim = 2**m
    flat = ints + (np.arange(rows, dtype=np.int64) * dim)[:, None]
    w = None if weights is None else np.asarray(weights, dtype=float).ravel()
    return np.bincount(flat.ravel(), weights=w, minlength=rows * dim).reshape(rows, dim) / shots


@overload
def unary_frequencies(result: JobResult, postselect: bool = False, *,
                      return_std: Literal[False] = False) -> tuple[np.ndarray, np.ndarray]: ...
@overload
def unary_frequencies(result: JobResult, postselect: bool = False, *,
                      return_std: Literal[True]) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
@overload
def unary_frequencies(result: JobResult, postselect: bool = False, *, return_std: bool = False
                      ) -> tuple[np.ndarray, ...]: ...
def unary_frequencies(result: JobResult, postselect: bool = False, *,
                      return_std: bool = False) -> tuple[np.ndarray, ...]:
    """Frequencies of the unary outcomes ``e_j`` (only bit ``j`` set), from bits or exact.

    Parameters
    ----------
    result : JobResult
    postselect : bool
        Divide by the kept (Hamming-weight-1) fraction of each row.
    return_std : bool
        Also return the standard errors of the frequencies (keyword only; the default keeps
        the two-value return).

    Returns
    -------
    (numpy.ndarray (rows, m), numpy.ndarray (rows,)[, numpy.ndarray (rows, m)])
        The (post-selected) unary probabilities and the Hamming-weight-1 fraction per row.
        From bits the fraction is the count of weight-1 shots over the shots (exactly 1.0
        when every shot has weight 1), not the sum of the ``m`` frequencies, whose rounding
        can leave it an ulp below 1. With ``return_std``, third: their standard errors,
        Wilson-floored (:mod:`qdensity.execution.intervals`, never zero for sampled rows;
        zero for exact ones). Raw shots: :func:`~qdensity.execution.intervals.
        binomial_standard_error` over the shots (post-selected: over the kept shots). A
        corrected run (``weights``): :func:`~qdensity.execution.intervals.shot_mean` of the
        per-shot indicators (the readout linearisations' delta method when mitigated;
        post-selected, of the ratio's per-shot influence ``(h_s - p_j [|b_s| = 1]) / kept``).
        Frequencies without bits but with ``shots`` use the binomial error of ``shots``.

    Examples
    --------
    Four shots on three clbits: ``e_0``, ``e_2``, ``e_2`` and one that leaked to weight 2:

    >>> import numpy as np
    >>> from qdensity.execution.plans import JobResult, unary_frequencies
    >>> bits = np.array([[[1, 0, 0], [0, 0, 1], [0, 0, 1], [1, 1, 0]]], dtype=bool)
    >>> p, kept = unary_frequencies(JobResult(bits=bits, shots=4))
    >>> p.tolist(), kept.tolist()
    ([[0.25, 0.0, 0.5]], [0.75])
    >>> p, kept = unary_frequencies(JobResult(bits=bits, shots=4), postselect=True)
    >>> (p * 3).round(12).tolist()  # renormalised over the 3 kept shots
    [[1.0, 0.0, 2.0]]
    """
    se = None
    if result.has_bits and result.weights is None:
        # raw shots: counts of the weight-1 outcomes from the set clbits, O(rows x shots)
        rows, shots, m = result.bits_shape
        shot, clbit = result.set_clbits()
        one = np.bincount(shot, minlength=rows * shots)[shot] == 1
        hit_count = np.bincount(shot[one] // shots * m + clbit[one],
                                minlength=rows * m).reshape(rows, m)
        n_kept = hit_count.sum(axis=1)
        p = hit_count / shots
        kept = n_kept / shots
        if return_std:
            if postselect:
                n_ps = np.maximum(n_kept, 1)[:, None]
                se = binomial_standard_error(hit_count / n_ps, n_ps)
            else:
                se = binomial_standard_error(p, shots)
    elif result.bits is not None:
        b = result.bits
        weight_one = b.sum(axis=-1) == 1
        hits = b & weight_one[..., None]
        shots = b.shape[1]
        w = np.asarray(result.weights, dtype=float)
        p = np.einsum("rs,rsm->rm", w, hits) / shots
        kept = np.einsum("rs,rs->r", w, weight_one) / shots
        if return_std:
            x = hits.astype(float)
            if postselect and np.all(kept > 0):
                ratio = p / kept[:, None]
                x = (x - ratio[:, None, :] * weight_one[..., None]) / kept[:, None, None]
                width = 1.0 / np.minimum(kept, 1.0)[:, None]
            else:
                width = 1.0
            _, se = shot_mean(x, width, weights=w, effective_shots=result.effective_shots,
                              linearisations=result.readout)
    else:
        probs = result.probabilities
        m = int(round(np.log2(probs.shape[1])))
        p = probs[:, 1 << np.arange(m)]
        kept = p.sum(axis=1)
        if return_std:
            if result.shots:
                q = p / np.where(kept > 0, kept, 1.0)[:, None] if postselect else p
                n = np.maximum(kept * result.shots, 1.0)[:, None] if postselect else result.shots
                se = binomial_standard_error(np.clip(q, 0.0, 1.0), n)
            else:
                se = np.zeros_like(p)
    if postselect:
        if np.any(kept <= 0):
            raise ValueError(f"rows {np.flatnonzero(kept <= 0).tolist()} keep no outcome of "
                             "Hamming weight 1")
        p = p / kept[:, None]
    if not return_std:
        return p, kept
    assert se is not None  # every branch above sets it with return_std
    return p, kept, se
