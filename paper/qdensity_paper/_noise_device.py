"""Unary outputs of a density QNN as a noisy device estimates them, four ways from one sample.

The ``noise`` experiment asks what a hardware team would measure: a trained unary model
(loader + RBS sub-unitaries, readout ``unary_probabilities``, paper Fig. 2) is sampled on a
noisy target, and its output ``f(x) = sum_k alpha_k p_k(x)`` (eq. 3, ``p_k`` the probabilities
of the unary outcomes ``e_j`` after sub-unitary ``k``) is estimated from the *same counts* in
four ways:

``raw``
    ``p_k(e_j) = counts(e_j) / shots``: what leaks out of the Hamming-weight-1 subspace is
    simply lost, so the outputs sum to the kept fraction ``kappa <= 1``.
``ps``
    Hamming-weight-1 post-selection: the same frequencies divided by the weight-1 fraction.
``m3``
    mthree readout mitigation by the engine (``SamplerEngine(mitigation="m3")``: per-shot
    weights over the same shots), the unary entries of the corrected distribution read off
    unrenormalised.
``m3_ps``
    Mitigation, then post-selection (divided by the mitigated weight-1 fraction), the
    composition of :func:`~qdensity.execution.sampler.mitigated.mitigated_expectation`.

The shots per data point are split over the sub-unitaries in proportion to ``alpha``
(stratified sampling, :func:`allocate_shots`): a pure model (K = 1) and a density model get
the same shots per prediction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from qdensity.execution.job_results import bits_to_probabilities
from qdensity.execution.plans import CircuitJob, measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.mitigation import hamming_weights

__all__ = ["VARIANTS", "allocate_shots", "DeviceOutputs", "device_outputs"]

#: The four estimates, in plotting order.
VARIANTS = ("raw", "ps", "m3", "m3_ps")


def allocate_shots(alpha, total: int) -> np.ndarray:
    """Split ``total`` shots over sub-unitaries: one each, the rest in proportion to ``alpha``.

    The ``total - K`` remaining shots go out by largest remainder, so the counts sum to
    ``total`` exactly and every sub-unitary is sampled (the stratified estimator
    ``sum_k alpha_k p_k`` stays unbiased).

    Parameters
    ----------
    alpha : array_like, shape (K,)
        Mixture weights (non-negative, summing to 1).
    total : int
        Shots per data point, at least ``K``.

    Returns
    -------
    numpy.ndarray of int, shape (K,)

    Raises
    ------
    ValueError
        If ``total < K`` or ``alpha`` is not a probability vector.

    Examples
    --------
    >>> allocate_shots([0.5, 0.25, 0.25], 11).tolist()
    [5, 3, 3]
    """
    a = np.asarray(alpha, dtype=float).ravel()
    if a.size == 0 or np.any(a < -1e-12) or not np.isclose(a.sum(), 1.0, atol=1e-8):
        raise ValueError(f"alpha must be a probability vector, got {a.tolist()}")
    k = a.size
    if isinstance(total, bool) or not isinstance(total, (int, np.integer)) or total < k:
        raise ValueError(f"shots per data point must be an int >= K = {k} (one per "
                         f"sub-unitary), got {total!r}")
    extra = (int(total) - k) * np.clip(a, 0.0, None)
    out = np.floor(extra).astype(int)
    left = int(total) - k - int(out.sum())
    if left:
        out[np.argsort(-(extra - out), kind="stable")[:left]] += 1
    return out + 1


@dataclass
class DeviceOutputs:
    """Device estimates of a unary model's outputs on a batch (see the module docstring).

    Attributes
    ----------
    values : dict
        Variant (``"raw"``, ``"ps"``, and with ``mitigation="m3"`` ``"m3"``, ``"m3_ps"``) ->
        numpy.ndarray (B, n) of estimated ``f(x)``.
    kept : dict
        ``"raw"`` (and ``"m3"``) -> numpy.ndarray (B,): the alpha-weighted Hamming-weight-1
        fraction of the raw (mitigated) distributions.
    overhead : numpy.ndarray, shape (B,)
        mthree's mitigation overhead, alpha-weighted (ones without mitigation).
    shots : numpy.ndarray of int, shape (K,)
        Shots per sub-unitary per data point.
    two_qubit_gates : list of int
        Two-qubit gates of each sub-unitary's compiled circuit (encoding included).
    """

    values: dict
    kept: dict
    overhead: np.ndarray
    shots: np.ndarray
    two_qubit_gates: list


def _unary(dist: np.ndarray, n: int) -> np.ndarray:
    return dist[:, 1 << np.arange(n)]


def device_outputs(model, X, *, engine: SamplerEngine, shots: int) -> DeviceOutputs:
    """Sample every sub-unitary of ``model`` on ``X`` once; estimate ``f(x)`` four ways.

    Parameters
    ----------
    model : DensityQNN
        Unary encoding, RBS/FBS sub-unitaries, ``readout="unary_probabilities"``.
    X : array_like, shape (B, d)
    engine : SamplerEngine
        The (noisy) device; its ledger records one job per sub-unitary (label ``eval_k<k>``).
        With ``mitigation="m3"`` (and no ``postselect``: the post-selected variants are read
        off here) the ``m3`` and ``m3_ps`` estimates come from its shot weights; the overhead
        is ``M = N / N_eff``.
    shots : int
        Shots per data point, split over the sub-unitaries by :func:`allocate_shots`.

    Returns
    -------
    DeviceOutputs
    """
    if not isinstance(engine, SamplerEngine):
        raise TypeError(f"engine must be a SamplerEngine, got {type(engine).__name__}")
    if engine.postselect is not None:
        raise ValueError("device_outputs reads the post-selected variants off the shots itself; "
                         "pass an engine without postselect")
    if model.readout != "unary_probabilities":
        raise ValueError(f"device_outputs needs readout='unary_probabilities', got "
                         f"{model.readout!r}")
    X = np.atleast_2d(np.asarray(X, dtype=float))
    n = model.num_qubits
    alpha = np.broadcast_to(model.alpha(X), (X.shape[0], model.num_subunitaries))
    per_k = allocate_shots(alpha.mean(axis=0), shots)
    jobs = [CircuitJob(measured(model.circuit(k)), model.rows(k, X), int(per_k[k]),
                       f"eval_k{k}") for k in range(model.num_subunitaries)]
    results = engine.run(jobs)
    ones = hamming_weights(n) == 1
    mitigated = engine.mitigation == "m3"
    names = VARIANTS if mitigated else VARIANTS[:2]
    values = {v: np.zeros((X.shape[0], n)) for v in names}
    kept = {v: np.zeros(X.shape[0]) for v in names[::2]}
    overhead = np.zeros(X.shape[0])
    gates = []
    for k, (job, res) in enumerate(zip(jobs, results, strict=True)):
        compiled = engine.compiled(job.circuit)
        gates.append(sum(1 for inst in compiled.data if inst.operation.num_qubits == 2
                         and inst.operation.name not in ("barrier", "measure")))
        a = alpha[:, k:k + 1]
        parts = {"raw": bits_to_probabilities(res.bits)}
        if mitigated:
            parts["m3"] = res.probabilities  # the shots weighted by the engine's M3
            overhead += alpha[:, k] * job.shots / res.effective_shots
        else:
            overhead += alpha[:, k]
        for name, dist in parts.items():
            weight_one = dist[:, ones].sum(axis=1)
            kept[name] += alpha[:, k] * weight_one
            values[name] += a * _unary(dist, n)
            safe = np.where(weight_one > 0, weight_one, 1.0)
            # a row that keeps nothing contributes nothing (all shots leaked out)
            values[f"{name}_ps" if name == "m3" else "ps"] += a * _unary(dist, n) / safe[:, None]
    return DeviceOutputs(values, kept, overhead, per_k, gates)
