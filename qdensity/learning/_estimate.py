"""Sampled outputs of a fitted estimator: the body of ``QNNClassifier.estimate`` /
``QNNRegressor.estimate``.

Every sub-unitary ``k`` runs on every encoded row with ``shots`` shots (one PUB per
sub-unitary, all in one submission). Each shot ``s`` gives a vector ``v_s``: the indicator of
its unary outcome ``e_j`` (``readout="unary_probabilities"``) or the diagonal observable's
value (``readout="observable"``); the corrected mean ``F_k`` of the ``v_s`` (the engine's
mitigation and post-selection weights) estimates the sub-unitary's output, and
``F = sum_k alpha_k(x) F_k`` the model's (eq. 3). The answer is the estimator's head
``g(F)`` (the read-out layer, then softmax for the classifier). Its standard error is the
delta method on the samples: with ``J = dg/dF`` at ``F``, the per-shot values ``J v_s`` have
mean ``J F_k``, and their spread over the shots (:func:`~qdensity.execution.intervals.
shot_mean`, Wilson-floored, or a mitigated row's linearisation) gives each sub-unitary's
share; shares add with weights ``alpha_k^2``, and a readout calibration that every
sub-unitary shares adds once with weight ``(sum_k alpha_k dV_k/de)^2``.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING

import numpy as np
from sklearn.base import is_classifier
from sklearn.utils.validation import check_is_fitted

from qdensity.execution.intervals import shot_mean
from qdensity.execution.plans import CircuitJob, Estimate, measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.models.mixtures import softmax
from qdensity.validation import MAX_DENSE_ENTRIES, check_positive_int, check_type

__all__ = ["sampled_estimate", "EstimateMixin", "fit_engine"]


def _per_shot(model, bits: np.ndarray) -> np.ndarray:
    """Per-shot output vectors ``v_s`` (rows, shots, m) from the measured bits."""
    if model.readout == "unary_probabilities":
        return (bits & (bits.sum(axis=-1) == 1)[..., None]).astype(float)
    paulis = model.observable.paulis  # diagonal: sum_t c_t (-1)^(b . z_t), no 2^n table
    coeff = np.real(np.asarray(model.observable.coeffs) * (-1j) ** paulis.phase)
    parity = (bits.astype(np.int64) @ paulis.z.T.astype(np.int64)) % 2
    return ((1.0 - 2.0 * parity) @ coeff)[..., None]


def _exact_outputs(model, probs: np.ndarray) -> np.ndarray:
    """Output vectors (rows, m) from exact outcome probabilities."""
    n = model.num_qubits
    if model.readout == "unary_probabilities":
        return probs[:, 1 << np.arange(n)]
    from qdensity.execution.observables import diagonal_values

    values = diagonal_values(model.observable.paulis, np.real(model.observable.coeffs), n)
    return (probs @ values)[:, None]


def _head_jacobian(head, F: np.ndarray, classifier: bool) -> tuple[np.ndarray, np.ndarray]:
    """``g(F)`` (B, C) and ``dg/dF`` (B, C, m) of the read-out (softmax after it for a
    classifier), from the layer's own backward on a copy (the fitted layer is untouched)."""
    if head is None:
        out, J = F.copy(), np.broadcast_to(np.eye(F.shape[1]), (F.shape[0],) + (F.shape[1],) * 2)
    else:
        layer = copy.deepcopy(head)
        out = layer.forward(F)
        J = np.empty((F.shape[0], out.shape[1], F.shape[1]))
        for c in range(out.shape[1]):
            seed = np.zeros_like(out)
            seed[:, c] = 1.0
            J[:, c, :] = layer.backward(seed)
    if classifier:
        P = softmax(out)
        dP = P[:, :, None] * (np.eye(P.shape[1])[None] - P[:, None, :])  # dP_c / dlogit_d
        return P, np.einsum("bcd,bdm->bcm", dP, J)
    return out, np.asarray(J)


def _share(res, x: np.ndarray, width: np.ndarray, alpha_k: np.ndarray, calibration: dict):
    """Variance share (B, C) of one sub-unitary: ``alpha_k^2 Var(mean of J v_s)``; a mitigated
    row's calibration part is collected in ``calibration`` instead (shared by every k)."""
    _, se = shot_mean(x, width, weights=res.weights, effective_shots=res.effective_shots)
    var = se**2
    if res.readout is not None:
        w = res.weights
        for r, lin in enumerate(res.readout):
            if lin is None:
                continue
            mean = (w[r][:, None] * x[r]).mean(axis=0)
            total = lin.variance(x[r], mean)
            cal = lin.calibration_gradient(x[r], mean)
            for key, (dv, e, n) in cal.items():
                total = total - dv**2 * e * (1 - e) / n
                acc = calibration.setdefault((r, key), [np.zeros_like(mean), e, n])
                acc[0] = acc[0] + alpha_k[r] * np.asarray(dv)
            var[r] = np.maximum(total, 0.0) + width[r]**2 / (4.0 * lin.kept_shots**2)
    return alpha_k[:, None] ** 2 * var


def fit_engine(engine, seed):
    """The engine one ``fit`` draws from: for a seeded :class:`SamplerEngine` and an integer
    estimator ``seed``, ``engine.with_seed(s)`` with ``s`` derived from both seeds (the same
    shots on every refit; the engine's ledger still records them); else ``engine`` itself.

    Parameters
    ----------
    engine : "exact", an exact engine or SamplerEngine
    seed : int, numpy.random.Generator or None
        The estimator's seed.

    Returns
    -------
    the engine to train with
    """
    if not isinstance(engine, SamplerEngine) or engine.seed is None:
        return engine
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        return engine  # a Generator or None: fits draw afresh, as the estimator does
    stream = np.random.SeedSequence([engine.seed % 2**63, int(seed) % 2**63, 0xF17])
    return engine.with_seed(int(stream.generate_state(1, dtype=np.uint32)[0]))


def sampled_estimate(est, Z: np.ndarray, engine, shots: int, classifier: bool) -> Estimate:
    """``g(F)`` and its standard error for encoded rows ``Z`` (B, d); see the module text.

    Returns
    -------
    Estimate
        ``value`` and ``standard_error`` of shape (B, C) (C classes, or regression targets).
    """
    model = est.model_
    if model.readout == "unary_amplitudes":
        raise ValueError("estimate() samples outputs, and shots do not see the signs of "
                         "readout='unary_amplitudes'; fit with readout='unary_probabilities' "
                         "(the default) or use predict (exact)")
    if model.readout == "observable" and np.any(model.observable.paulis.x):
        raise ValueError("estimate() needs a diagonal (I/Z) observable; this model's "
                         "observable has X or Y terms")
    K, B = model.num_subunitaries, Z.shape[0]
    m = model.num_qubits if model.readout == "unary_probabilities" else 1
    per_row = shots * max(m, est._num_targets)
    if B * per_row > MAX_DENSE_ENTRIES:
        raise ValueError(f"estimate() holds {shots} shots x {max(m, est._num_targets)} values "
                         f"per row; {B} rows exceed {MAX_DENSE_ENTRIES} entries: estimate at "
                         f"most {max(MAX_DENSE_ENTRIES // per_row, 1)} rows at a time")
    if est.pre_ is not None:
        Z = copy.deepcopy(est.pre_).forward(Z)
    jobs = [CircuitJob(measured(model.circuit(k)), model.rows(k, Z), shots, f"estimate_k{k}")
            for k in range(K)]
    results = engine.run(jobs)  # one submission, one PUB per sub-unitary
    alpha = np.broadcast_to(model.alpha(Z), (B, K))
    shot_vectors: list[np.ndarray | None]
    v: np.ndarray | None  # one sub-unitary's per-shot values (None: an exact run)
    shot_vectors, outs = [], []
    for res in results:
        if res.bits is None:  # an exact run
            shot_vectors.append(None)
            outs.append(_exact_outputs(model, res.probabilities))
            continue
        v = _per_shot(model, res.bits)
        shot_vectors.append(v)
        w = np.ones(v.shape[:2]) if res.weights is None else np.asarray(res.weights)
        outs.append(np.einsum("rs,rsm->rm", w, v) / v.shape[1])
    F = np.einsum("bk,bkm->bm", alpha, np.stack(outs, axis=1))
    value, J = _head_jacobian(est.post_, F, classifier)
    var = np.zeros_like(value)
    calibration: dict = {}
    bound = float(np.abs(model.observable.coeffs).sum())
    for k, (res, v) in enumerate(zip(results, shot_vectors, strict=True)):
        if v is None:
            continue
        x = np.einsum("rsm,rcm->rsc", v, J)  # per-shot values J v_s
        if model.readout == "unary_probabilities":  # v_s is e_j or 0
            cols = np.concatenate([J, np.zeros(J.shape[:2] + (1,))], axis=2)
        else:  # v_s within +-sum_t |c_t|, the observable's norm bound
            cols = np.concatenate([J * bound, -J * bound], axis=2)
        width = cols.max(axis=2) - cols.min(axis=2)
        var += _share(res, x, width, alpha[:, k], calibration)
    for (r, _), (dv, e, n) in calibration.items():
        var[r] += dv**2 * e * (1 - e) / n
    return Estimate(value, np.sqrt(var))


class EstimateMixin:
    """The estimators' sampled answer: ``estimate``."""

    if TYPE_CHECKING:  # what the estimator that mixes this in has
        def transform(self, X) -> np.ndarray: ...

    def estimate(self, X, *, engine=None, shots: int = 1000, seed=None) -> Estimate:
        """The fitted answer sampled with shots, with standard errors from the samples.

        Every sub-unitary runs on every encoded row with ``shots`` shots (one PUB per
        sub-unitary, one submission); their corrected frequencies are mixed with
        ``alpha_k(x)`` (eq. 3) and put through the read-out (and softmax). Standard errors:
        the delta method on the per-shot values (Wilson-floored, mitigated rows through
        their linearisation, a shared readout calibration counted once); see
        :mod:`qdensity.learning._estimate`.

        Parameters
        ----------
        X : array_like, shape (N, n_features_in_)
        engine : SamplerEngine, optional
            Where the shots run; readout mitigation and post-selection are its options
            (``SamplerEngine(target=..., mitigation="m3", postselect=...)``); its ledger
            records the shots. Default: a fresh noiseless Aer engine seeded with ``seed``.
        shots : int
            Shots per circuit (per row and sub-unitary), ``>= 2``.
        seed : int, Generator or None
            Seeds the default engine; with ``engine`` it must be None (seed the engine).

        Returns
        -------
        Estimate
            ``value`` shaped like :meth:`predict_proba` (classifier, (N, C)) or
            :meth:`predict` (regressor, (N,) or (N, m)); ``standard_error`` the same shape.

        Raises
        ------
        ValueError
            ``readout="unary_amplitudes"`` (shots do not see signs), a non-diagonal
            observable, ``shots < 2``, or ``seed`` together with ``engine``.
        """
        check_is_fitted(self, "model_")
        check_type(engine, "engine", SamplerEngine, "a SamplerEngine", allow_none=True)
        shots = check_positive_int(shots, "shots", minimum=2)
        if engine is not None and seed is not None:
            raise ValueError("seed seeds the default engine; with engine=..., seed that engine")
        Z = self.transform(X)
        engine = SamplerEngine(seed=seed, progress=False) if engine is None else engine
        est = sampled_estimate(self, Z, engine, shots, classifier=is_classifier(self))
        return self._shape_estimate(est)

    def _shape_estimate(self, est: Estimate) -> Estimate:
        return est
