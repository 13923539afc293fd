"""The LCU QNN as a trainable model (paper Fig. 1a, Supp. C): the post-selected state
``A|x> / ||A|x>||`` with ``A = sum_k alpha_k(x) U_k(theta_k)``, on unary data.

A density QNN and its LCU counterpart share everything (sub-unitaries, angles, mixture); only
the combination differs. The density model mixes the *outputs*,
``p_j = sum_k alpha_k |y_kj|^2``; the LCU model mixes the *amplitudes*,
``v = sum_k alpha_k y_k`` with ``y_k = O_k x`` (the unary engine's orthogonal matrix of
``U_k``), and reads ``p_j = v_j^2 / ||v||^2`` after post-selecting the mixing register on
``|0...0>``, which succeeds with probability ``||v||^2 <= 1``
(:func:`~qdensity.circuits.preparation.lcu_circuit` builds that circuit gate by gate).
The paper leaves the success probability out of its LCU numerics; :meth:`LCUQNN.success_probability`
reports it, since it multiplies the shots an LCU model costs.

:meth:`LCUQNN.sampling_plan` / :meth:`LCUQNN.sample` run the same model through the gate-level
LCU circuit (:func:`~qdensity.circuits.preparation.lcu_template`, the mixing angles bound per
data point so a data-dependent ``alpha`` needs one template) on any ``SamplerV2``, post-select
``mix = 0...0`` on the measured bits and estimate the unary probabilities and the success
probability (:func:`~qdensity.execution.sampler.postselection.postselected_unary`).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.execution.plans import CircuitJob, JobResult, Plan, measured
from qdensity.execution.sampler.postselection import PostselectedUnary, postselected_unary
from qdensity.execution.unary import vjp
from qdensity.models.density import DensityQNN, bind_rows
from qdensity.models.encoding import Encoding
from qdensity.models.exact import unary_circuits, uses_unary_engine
from qdensity.models.mixtures import Mixture
from qdensity.validation import (
    MAX_SUBUNITARIES,
    Array,
    Circuit,
    Instance,
    Options,
    Seed,
    SequenceOf,
    validates,
)

__all__ = ["LCUQNN"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES),
    mixture=[Instance(Mixture), Array(ndim=1, max_size=MAX_SUBUNITARIES), None], seed=Seed(),
)
class LCUQNN:
    """LCU QNN on unary data: ``p(x) = |A x|^2 / ||A x||^2``, ``A = sum_k alpha_k(x) O_k``.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        Hamming-weight-preserving RBS/FBS circuits on ``n`` qubits (trainable parameters by
        name, shared names share a value, as in :class:`~qdensity.models.DensityQNN`).
    mixture : Mixture, array_like or None
        ``alpha``: a fixed distribution, :class:`~qdensity.models.mixtures.SoftmaxMixture`
        (trainable)
        or :class:`~qdensity.models.mixtures.GatedMixture` (data-dependent, the paper's MoE gate).
    seed : int, numpy.random.Generator or None
        Initial angles uniform in ``[-pi, pi)`` (zeros when None).

    Attributes
    ----------
    density : DensityQNN
        The density model with the same sub-unitaries, angles and mixture (it holds the
        parameters; setting ``theta`` on either changes both).

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import by_moments
    >>> from qdensity.models.mixtures import SoftmaxMixture
    >>> dec = by_moments(round_robin(4))
    >>> lcu = LCUQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), seed=0)
    >>> X = np.eye(4)[:2] + 0.5
    >>> lcu.predict(X).sum(axis=1).round(12).tolist()
    [1.0, 1.0]
    >>> bool(np.all(lcu.success_probability(X) <= 1.0))
    True
    """

    def __init__(self, sub_unitaries: Sequence[QuantumCircuit], mixture=None, *, seed=None):
        subs = list(sub_unitaries)
        self.density = DensityQNN(subs, mixture, encoding=Encoding.unary(subs[0].num_qubits),
                                  readout="unary_amplitudes", seed=seed)
        if not uses_unary_engine(self.density):
            raise ValueError("sub_unitaries must be RBS/FBS (Hamming-weight-preserving) circuits: "
                             "the LCU model runs on the unary engine")

    def __getstate__(self) -> dict:
        """The model without its built LCU template (:meth:`template` builds it again)."""
        return {k: v for k, v in list(self.__dict__.items()) if k != "_template"}

    @classmethod
    def from_density(cls, model: DensityQNN) -> LCUQNN:
        """The LCU counterpart of a unary density model, sharing its sub-unitaries and mixture and
        starting from a copy of its angles (Supp. C: train the sub-unitaries, then combine).

        Parameters
        ----------
        model : DensityQNN
            RBS/FBS sub-unitaries on a unary encoding.

        Returns
        -------
        LCUQNN
        """
        if not isinstance(model, DensityQNN):
            raise TypeError(f"model must be a DensityQNN, got {type(model).__name__}")
        out = cls(model.sub_unitaries, model.mixture)
        out.theta = model.theta.copy()
        return out

    @property
    def num_qubits(self) -> int:
        return self.density.num_qubits

    @property
    def num_subunitaries(self) -> int:
        return self.density.num_subunitaries

    @property
    def mixture(self) -> Mixture:
        return self.density.mixture

    @property
    def theta(self) -> np.ndarray:
        """Angles of all sub-unitaries, shape (P,)."""
        return self.density.theta

    @theta.setter
    def theta(self, value) -> None:
        self.density.theta = value

    def _parts(self, X) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Y`` (B, K, n) sub-unitary amplitudes, ``alpha`` (B, K), ``v`` (B, n)."""
        Y = self.density.expert_outputs(X, method="unary")
        alpha = self.mixture.alpha(X)
        alpha = np.broadcast_to(alpha, Y.shape[:2])
        return Y, alpha, np.einsum("bk,bkn->bn", alpha, Y)

    def amplitudes(self, X) -> np.ndarray:
        """Unnormalised post-selected amplitudes ``v = sum_k alpha_k O_k x / ||x||``.

        Parameters
        ----------
        X : array_like, shape (B, n)

        Returns
        -------
        numpy.ndarray, shape (B, n)
        """
        return self._parts(X)[2]

    def success_probability(self, X) -> np.ndarray:
        """Probability ``||A x||^2 / ||x||^2`` that the mixing register post-selects on zeros.

        Parameters
        ----------
        X : array_like, shape (B, n)

        Returns
        -------
        numpy.ndarray, shape (B,), in ``[0, 1]``
        """
        v = self.amplitudes(X)
        return np.einsum("bn,bn->b", v, v)

    def predict(self, X) -> np.ndarray:
        """Post-selected unary probabilities ``v_j^2 / ||v||^2``.

        Parameters
        ----------
        X : array_like, shape (B, n)

        Returns
        -------
        numpy.ndarray, shape (B, n); rows sum to one.

        Raises
        ------
        ValueError
            If ``A x = 0`` for a row (post-selection never succeeds, the output is undefined).
        """
        v = self.amplitudes(X)
        norm2 = np.einsum("bn,bn->b", v, v)
        if np.any(norm2 <= 1e-300):
            rows = np.flatnonzero(norm2 <= 1e-300).tolist()
            raise ValueError(f"post-selection never succeeds for rows {rows} of X (A x = 0)")
        return v**2 / norm2[:, None]

    def template(self) -> QuantumCircuit:
        """The unmeasured LCU circuit with ``V(x)``, angles and mixing angles as parameters.

        Returns
        -------
        QuantumCircuit
            ``K + n`` qubits (``mix`` then ``data``), built once and kept.
        """
        if getattr(self, "_template", None) is None:
            from qdensity.circuits.preparation import lcu_template

            if self.num_subunitaries < 2:
                raise ValueError("the sampled LCU circuit needs K >= 2 sub-unitaries (with "
                                 "K = 1 the model is its single circuit)")
            assert self.density.encoding is not None  # an LCU model has its unary encoding
            self._template = lcu_template(self.density.sub_unitaries,
                                          self.density.encoding.circuit)
        return self._template

    def circuit_rows(self, X) -> np.ndarray:
        """Parameter rows of :meth:`template` for data ``X``: ``V(x)``'s angles, the current
        ``theta`` and ``loader_angles(sqrt(alpha(x)))``.

        Parameters
        ----------
        X : array_like, shape (B, n)

        Returns
        -------
        numpy.ndarray, shape (B, template().num_parameters)
        """
        from qdensity.circuits.loaders import loader_angles

        tpl = self.template()
        X = self.density._check_X(X)
        enc = self.density.encoding
        assert enc is not None  # an LCU model has its unary encoding
        cols = dict(zip(enc.circuit.parameters, enc.values(X).T, strict=True))
        by_name = {p.name: p for p in tpl.parameters}
        alpha = np.broadcast_to(self.mixture.alpha(X), (X.shape[0], self.num_subunitaries))
        angles = loader_angles(np.sqrt(np.clip(alpha, 0.0, None)))
        for j, name in enumerate(tpl.metadata["alpha_parameters"]):
            cols[by_name[name]] = angles[:, j]
        for p in tpl.parameters:
            if p not in cols:
                cols[p] = np.full(X.shape[0], self.theta[self.density._index[p]])
        return bind_rows(tpl, cols)

    def sampling_plan(self, X, shots: int | None) -> Plan:
        """Plan: the LCU circuit for every row of ``X`` (one template, one PUB), post-selected.

        Parameters
        ----------
        X : array_like, shape (B, n)
        shots : int or None
            Shots per data point (None: exact probabilities, for checks on small circuits).

        Returns
        -------
        Plan
            Post-processing returns a :class:`~.postselection.PostselectedUnary`
            (estimates of :meth:`predict` and :meth:`success_probability` with standard errors).
        """
        K, n = self.num_subunitaries, self.num_qubits
        job = CircuitJob(measured(self.template()), self.circuit_rows(X), shots, "lcu")
        return Plan([job], partial(_lcu_post, K, n),
                    f"LCU QNN, K = {K}, n = {n}, post-select mix = 0")

    def sample(self, X, shots: int, *, engine=None, seed=None) -> PostselectedUnary:
        """Estimate :meth:`predict` and :meth:`success_probability` from ``shots`` per data point.

        Parameters
        ----------
        X : array_like, shape (B, n)
        shots : int
            Shots per data point; only the successful ones estimate the probabilities.
        engine : SamplerEngine, optional
            Default: noiseless Aer ``SamplerV2`` seeded with ``seed``.
        seed : int or numpy.random.Generator, optional

        Returns
        -------
        PostselectedUnary
        """
        from qdensity.execution.sampler.engine import SamplerEngine
        from qdensity.validation import check_positive_int, check_seed, check_type

        check_positive_int(shots, "shots")
        check_type(engine, "engine", SamplerEngine, "a SamplerEngine", allow_none=True)
        check_seed(seed)
        if engine is None:
            engine = SamplerEngine(seed=seed, progress=False)
        return self.sampling_plan(X, shots).run(engine)

    @validates(wrt=Options(("all", "theta", "mixture")))
    def vjp(self, X, grad_P, *, wrt: str = "all") -> tuple[np.ndarray, np.ndarray]:
        """Gradient of ``sum_bj grad_P[b, j] p_bj`` w.r.t. the angles and the mixture parameters.

        With ``s = ||v||^2``: ``dL/dv_i = (2 v_i / s) (g_i - <g, p>)``; then
        ``dL/dy_k = alpha_k dL/dv`` goes through the unary engine's reverse pass and
        ``dL/dalpha_k = <dL/dv, y_k>`` through the mixture.

        Parameters
        ----------
        X : array_like, shape (B, n)
        grad_P : array_like, shape (B, n)
        wrt : {"all", "theta", "mixture"}
            Which gradients to compute; the other is returned as zeros (Supp. C trains the
            sub-unitaries first, then the mixture alone: the angles' reverse passes, K of
            them per batch, are skipped).

        Returns
        -------
        grad_theta : numpy.ndarray, shape (P,)
            Summed over the batch; shared parameters summed over their occurrences.
        grad_mixture : numpy.ndarray, shape (M,)
        """
        Y, alpha, v = self._parts(X)
        g = np.asarray(grad_P, dtype=float)
        if g.shape != v.shape:
            raise ValueError(f"grad_P must have shape {v.shape}, got {g.shape}")
        s = np.einsum("bn,bn->b", v, v)[:, None]
        P = v**2 / s
        gv = 2.0 * v / s * (g - np.einsum("bn,bn->b", g, P)[:, None])
        grad_theta = np.zeros_like(self.theta)
        if wrt != "mixture":
            Xn = np.asarray(X, dtype=float)
            Xn = Xn / np.linalg.norm(Xn, axis=1, keepdims=True)
            for k, circ in enumerate(unary_circuits(self.density)):  # compiled once per model
                idx = self.density.subunitary_parameter_indices(k)
                gk, _ = vjp(circ, Xn, self.theta[idx], alpha[:, k, None] * gv, reduce="sum")
                np.add.at(grad_theta, idx, gk)
        if wrt == "theta":
            return grad_theta, np.zeros_like(np.asarray(self.mixture.params, dtype=float))
        grad_alpha = np.einsum("bn,bkn->bk", gv, Y)
        grad_mixture = self.mixture.vjp(X, grad_alpha)
        return grad_theta, np.asarray(grad_mixture, dtype=float)


def _lcu_post(num_mix: int, num_data: int, results: list[JobResult]) -> PostselectedUnary:
    """Post-select ``mix`` (clbits ``0..K-1``) on zeros; data on clbits ``K..K+n-1``."""
    return postselected_unary(results[0], range(num_mix), range(num_mix, num_mix + num_data))
