"""Gradients of density QNNs ``f(x) = sum_k alpha_k(x) f_k(x)`` (paper Prop. 1, Cor. 1, 2; B.1):

* ``d f / d theta_p = sum_k alpha_k d f_k / d theta_p``: sub-unitary k's own circuit's gradient
  w.r.t. its own parameters, one k per independent parameter (Cor. 1), shared ones summed over
  every k that uses them (Prop. 1); the circuits are the sum over k of each one's circuits.
* ``d f / d alpha_k = f_k`` (forward values), chained through the mixture (softmax logits or
  the mixture-of-experts gate) by :meth:`qdensity.models.mixtures.Mixture.vjp`.

Each sub-unitary's Jacobian is a plan: ``"shift"`` (parameter shift, Supp. E), ``"commuting"``
(one commuting block: one circuit and a diagonalising layer, Bowles et al.'s Thm. 1, Supp. F.3;
``B_k`` blocks read out by a Pauli observable: ``2 B_k - 1`` circuits by
:func:`commuting_block_gradient`, ``2 sum_k B_k - K`` in all, Cor. 2) or ``"auto"`` (one block's
circuit where it applies, else block circuits when fewer than parameter shifts, else shifts).
"""

from __future__ import annotations

import gc
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from qdensity.circuits._copying import concatenated_view, gc_paused
from qdensity.execution._compile import circuit_digest
from qdensity.execution._lazy_jobs import LazyCircuitJob
from qdensity.execution.plans import Plan, _first_result, probabilities_plan
from qdensity.execution.samplers._hamming_compile import CompiledPrefix
from qdensity.gradients import _sparse
from qdensity.gradients._density_analysis import (
    _auto_prefers_commuting,
    _commuting_analysis,
    _fingerprint_of,
)
from qdensity.gradients._density_jobs import (
    _commuting_post,
    _forward_observable_post,
    _forward_unary_post,
    _shift_observable_post,
    commuting_jobs,
    forward_job,
    shared_loader_rows,
)
from qdensity.gradients.commuting import (
    commuting_gradient_count,
)
from qdensity.gradients.shift import parameter_shift_plan, shift_circuit_count
from qdensity.models._rows import encoding_columns, model_rows
from qdensity.models.decompositions import trainable_parameters
from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_SHOTS,
    MAX_SUBUNITARIES,
    Array,
    Instance,
    Interval,
    Options,
    validates,
)

__all__ = ["DensityGradient", "subunitary_jacobian_plan", "density_gradient_plan",
           "gradient_circuit_count", "METHODS"]

METHODS = ("auto", "shift", "commuting")


@validates(
    outputs=Array(ndim=None, min_size=0, finite=False),
    output_errors=Array(ndim=None, min_size=0, finite=False), jacobians=Instance(list),
    jacobian_errors=Instance(list),
)
@dataclass
class DensityGradient:
    """Everything the chain rule needs for one batch.

    Attributes
    ----------
    outputs : numpy.ndarray, shape (B, K, m)
        ``f_k`` per data row (m = 1 for an observable, n for unary probabilities).
    jacobians : list of numpy.ndarray, each (B, m, P_k), or of scipy.sparse.csr_array
        ``d f_k / d theta_k`` in sub-unitary k's parameter order; in the sparse layout
        (``density_gradient_plan``'s ``jacobian``) the dense array reshaped to ``(B * m, P_k)``
        (row ``b * m + j``: output ``j`` of data row ``b``; entries left out are exactly zero).
    output_errors, jacobian_errors : standard errors, same shapes and layout (zeros when
        exact; a sparse Jacobian's errors share its sparsity pattern).

    Examples
    --------
    >>> from qdensity import DensityQNN, Encoding, by_moments
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution import AdjointEngine
    >>> from qdensity.gradients import density_gradient_plan
    >>> model = DensityQNN(by_moments(round_robin(4)).sub_unitaries, encoding=Encoding.unary(4))
    >>> grad = density_gradient_plan(model, [[1., 2., 3., 4.]]).run(AdjointEngine())  # <Z_0>
    >>> grad.outputs.shape, [jac.shape for jac in grad.jacobians]  # (B, K, m), (B, m, P_k)
    ((1, 3, 1), [(1, 1, 2), (1, 1, 2), (1, 1, 2)])
    """

    outputs: np.ndarray
    output_errors: np.ndarray
    jacobians: list[np.ndarray]
    jacobian_errors: list[np.ndarray]


def _check_method(model, method: str) -> None:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if model.readout == "unary_amplitudes":
        raise ValueError("gradients on hardware need a probability or observable readout; "
                         "unary_amplitudes are trained on the unary engine")


def _circuit_of(model, k: int, view: bool = False):
    """``V(x) U_k`` (``U_k`` itself, not a copy, without an encoding: the analyses only read it
    and gradient circuits are copies; ``view``: sharing the model's gates, to be read only)
    and ``U_k``'s trainable parameters."""
    if model.encoding is None:
        circ = model.sub_unitaries[k]
    elif view:
        circ = concatenated_view(model.encoding.circuit, model.sub_unitaries[k])
    else:
        circ = model.circuit(k)
    return circ, trainable_parameters(model.sub_unitaries[k])


@validates(
    model=Instance('qdensity.models.density:DensityQNN'), k=Interval(int, 0, MAX_SUBUNITARIES),
    X=[Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), None], method=Options(METHODS),
    shots=[Interval(int, 1, MAX_SHOTS), None],
)
def subunitary_jacobian_plan(model, k: int, X=None, *, method: str = "auto",
                             shots: int | None = None) -> Plan:
    """Plan for ``d f_k / d theta_k`` over the rows of ``X``.

    Parameters
    ----------
    model : DensityQNN
    k : int
        Sub-unitary index.
    X : array_like, shape (B, d), optional
    method : {"auto", "shift", "commuting"}
    shots : int, optional
        Shots per circuit; exact when None.

    Returns
    -------
    Plan
        Post-processing returns an :class:`~qdensity.execution.plans.Estimate` of shape (B, m, P_k).
        ``plan.meta["method"]`` says which method was used.

    Examples
    --------
    >>> from qdensity import DensityQNN, by_moments
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import subunitary_jacobian_plan
    >>> model = DensityQNN(by_moments(round_robin(4)).sub_unitaries)  # 3 layers of 2 RBS
    >>> [subunitary_jacobian_plan(model, 1, method=m).num_circuits for m in ("shift", "auto")]
    [8, 1]
    """
    _check_method(model, method)
    circ, params = _circuit_of(model, k)
    return _jacobian_plan(model, k, circ, params, model.rows(k, X), method, shots)


def _jacobian_plan(model, k: int, circ, params, rows, method: str, shots,
                   fingerprint: tuple | None = None, sparse: bool = False,
                   prefix=None, job_rows=None) -> Plan:
    """:func:`subunitary_jacobian_plan` on the circuit and parameter rows already made
    (``fingerprint``: :func:`_fingerprint_of` ``(model, k)`` when already taken; ``sparse``: a
    commuting plan's post-processing returns the ``(value, error)`` pair in
    :mod:`qdensity.gradients._sparse`'s layout instead of a dense :class:`Estimate`;
    ``prefix``: ``V(x)``'s walk for the sampler's compiler, done once per plan; ``job_rows``:
    ``rows`` as the jobs built on read hold them, e.g. a
    :class:`~qdensity.execution._lazy_jobs.SharedRows`)."""
    if method in ("auto", "commuting"):
        try:
            plan = _commuting_plan(model, circ, params, rows, shots, k, fingerprint, sparse,
                                   prefix, job_rows)
        except ValueError:
            if method == "commuting":
                raise
        else:
            if method == "commuting" or _auto_prefers_commuting(model, circ, params, k,
                                                                plan.meta["gradient"]):
                plan.meta["method"] = "commuting"
                return plan
    if model.readout == "observable":
        inner = parameter_shift_plan(circ, model.observable, rows, parameters=params, shots=shots,
                                     label=f"shift_k{k}")

        post: Callable[[list], Any] = partial(_shift_observable_post, inner)
    else:
        # the n unary frequencies, read off the measured bits when sampled (no 2**n row)
        inner = parameter_shift_plan(circ, None, rows, parameters=params, shots=shots,
                                     label=f"shift_k{k}", unary=True)
        post = inner.postprocess

    plan = Plan(inner.jobs, post, inner.description, {"method": "shift"})
    return plan


def _commuting_plan(model, circ, params, rows, shots, k, fingerprint=None,
                    sparse: bool = False, prefix=None, job_rows=None) -> Plan:
    shared, grads = _commuting_analysis(model, circ, params, k, fingerprint)
    jobs, forward = commuting_jobs(model, k, circ, shared, rows, shots, prefix,  # built on read
                                   job_rows)
    return Plan(jobs, partial(_commuting_post, grads, shots, sparse=sparse),
                f"commuting gradient of sub-unitary {k}",
                {"gradient": shared, "forward_program": forward})


def _forward_plan(model, k: int, X, shots, circuit=None, rows=None, *,
                  owned: bool = False, program=None, job_rows=None) -> Plan:
    """``f_k``'s plan (``circuit``, ``rows``: ``model.circuit(k)``, ``model.rows(k, X)`` if made;
    ``owned``: ``circuit`` is this plan's copy, measured in place; ``program``: sampled from it)."""
    if program is not None and circuit is not None and rows is not None:
        inner = Plan([forward_job(model, k, circuit, rows if job_rows is None else job_rows,
                                  shots, program)], _first_result,
                     f"P(b) of {circuit.name}")
    elif model.readout == "observable":
        inner = model.expectation_plan(k, X, shots=shots)
        return Plan(inner.jobs, partial(_forward_observable_post, inner), inner.description)
    else:
        inner = probabilities_plan(model.circuit(k) if circuit is None else circuit,
                                   model.rows(k, X) if rows is None else rows, shots=shots,
                                   label=f"forward_k{k}", inplace=owned and circuit is not None)
    post_p = partial(_forward_unary_post, inner, 1 << np.arange(model.num_qubits))
    return Plan(inner.jobs, post_p, inner.description)


@validates(
    model=Instance('qdensity.models.density:DensityQNN'),
    X=[Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), None], method=Options(METHODS),
    shots=[Interval(int, 1, MAX_SHOTS), None], forward=Instance(bool),
    jacobian=Options(_sparse.JACOBIAN_LAYOUTS),
)
def density_gradient_plan(model, X=None, *, method: str = "auto", shots: int | None = None,
                          forward: bool = True, jacobian: str = "auto") -> Plan:
    """Plan for the outputs and Jacobians of every sub-unitary (Cor. 1 / Prop. 1).

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d), optional
    method : {"auto", "shift", "commuting"}
    shots : int, optional
        Shots per circuit row; exact when None.
    forward : bool
        Include the forward circuits (``f_k``, needed for ``d f / d alpha``).
    jacobian : {"auto", "dense", "sparse"}
        :attr:`DensityGradient.jacobians` and ``jacobian_errors`` as dense ``(B, m, P_k)``
        arrays or ``scipy.sparse.csr_array`` ``(B * m, P_k)`` (round-robin moments, n = 256:
        2.1 GB dense); ``"auto"``: dense to 64 MiB (``16 B m sum_k P_k`` bytes), as plan.meta says.

    Returns
    -------
    Plan
        Post-processing returns a :class:`DensityGradient`; ``plan.meta["gradient_circuits"]``
        is the gradient circuits per data point (forward excluded), summed over sub-unitaries.

    Examples
    --------
    >>> from qdensity import DensityQNN, Encoding, by_moments
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import density_gradient_plan
    >>> model = DensityQNN(by_moments(round_robin(4)).sub_unitaries, encoding=Encoding.unary(4))
    >>> density_gradient_plan(model, [[1., 2., 3., 4.]]).meta["gradient_circuits"]  # Table 1
    3
    """
    _check_method(model, method)
    K = model.num_subunitaries
    jac_plans, fwd_plans = [], []
    encoded = encoding_columns(model, X)  # V(x)'s angles: the same for every sub-unitary
    enc_key = (None if model.encoding is None  # V(x)'s structure, fingerprinted once
               else circuit_digest(model.encoding.circuit))
    m = 1 if model.readout == "observable" else model.num_qubits
    total_p = sum(len(model.subunitary_parameter_indices(k)) for k in range(K))  # sum_k P_k
    # V(x)'s walk for the sampler's compiler, once: every V(x) U_k begins with it
    prefix = (None if model.encoding is None or shots is None
              else CompiledPrefix(model.encoding.circuit))
    loader = None  # V(x)'s columns of every sub-unitary's rows, once (shared_loader_rows)
    with gc_paused():  # about 1,400 gates a sub-unitary at n = 256 (each view cleared)
        for k in range(K):  # each sub-unitary's circuit and rows made once, for both plans
            # V(x) U_k sharing the model's gates (read only): kept only when the plan's jobs
            # are all built on read (nothing holds it); else made again as a copy
            circ, params = _circuit_of(model, k, view=True)
            view = model.encoding is not None  # a circuit of this loop's own (not U_k)
            # model.rows(k, X), in circ's parameter order read off circ itself
            rows = model_rows(model, k, X, None, circ, encoded)
            if k == 0:
                B = rows.shape[0]
                layout = _sparse.choose_layout(jacobian, B, m, total_p)
            fingerprint = _fingerprint_of(model, k, enc_key)
            # the jobs built on read hold V(x)'s columns once per plan (loader: its block)
            job_rows, loader = shared_loader_rows(model, circ, rows, encoded, loader)
            plan = _jacobian_plan(model, k, circ, params, rows, method, shots, fingerprint,
                                  layout == "sparse", prefix, job_rows)
            if model.encoding is not None and not (
                    plan.meta.get("forward_program") is not None
                    and all(isinstance(j, LazyCircuitJob) for j in plan.jobs)):
                circ, _ = _circuit_of(model, k)
                view = False  # the copy becomes the forward circuit
                plan = _jacobian_plan(model, k, circ, params, rows, method, shots, fingerprint,
                                      layout == "sparse", prefix)
            jac_plans.append(plan)
            if forward:
                # with an encoding circ is model.circuit(k), a copy made here: the Jacobian's
                # analysis only read it and its circuits are copies, so it becomes the forward
                # circuit (measured in place); without one it is U_k itself, copied
                same = model.encoding is not None
                fwd_plans.append(_forward_plan(model, k, X, shots, circ if same else None, rows,
                                               owned=same, program=jac_plans[-1].meta.get(
                                                   "forward_program"), job_rows=job_rows))
            if view:  # read by the analyses alone, held by nothing: its instructions freed
                # now (a QuantumCircuit is a reference cycle, left to the collector, which is
                # paused here: at n = 1024 the 1,023 views of 1,535 gates would pile up)
                circ.clear()
            if k % 16 == 15:  # the cleared views' bits too: collected while young (cheap)
                gc.collect(0)
    plans = jac_plans + fwd_plans
    combined = Plan.combine(plans, "density gradient")
    bounds = np.cumsum([0] + [len(p.jobs) for p in plans]).tolist()  # each plan's results
    post = partial(_density_post, plans, bounds, K, B, layout == "sparse")
    per_point = sum(p.num_circuits for p in jac_plans) // max(B, 1)
    return Plan(combined.jobs, post, "density gradient",
                {"gradient_circuits": per_point, "jacobian": layout,
                 "methods": [p.meta.get("method") for p in jac_plans]})


@validates(model=Instance('qdensity.models.density:DensityQNN'), method=Options(METHODS))
def gradient_circuit_count(model, *, method: str = "auto") -> int:
    """``density_gradient_plan(model, method=method).meta["gradient_circuits"]``, counted.

    Gradient circuits per data point (forward excluded), summed over the sub-unitaries (Table
    1), from the plan's analyses and method choice without building its circuits or parameter
    rows (one commuting block: :func:`~qdensity.gradients.commuting.commuting_gradient_count`;
    shift: :func:`~qdensity.gradients.shift.shift_circuit_count`; else the plan's analysis).

    Parameters
    ----------
    model : DensityQNN
    method : {"auto", "shift", "commuting"}

    Returns
    -------
    int

    Examples
    --------
    >>> from qdensity import DensityQNN, by_moments
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import gradient_circuit_count
    >>> model = DensityQNN(by_moments(round_robin(4)).sub_unitaries)  # n = 4: 6 RBS angles
    >>> gradient_circuit_count(model), gradient_circuit_count(model, method="shift")  # Table 1
    (3, 24)
    """
    _check_method(model, method)
    total = 0
    for k in range(model.num_subunitaries):
        circ, params = _circuit_of(model, k)
        count = None
        if method in ("auto", "commuting"):
            count = _commuting_count(model, circ, params, k, method)
        if count is None:
            obs = model.observable if model.readout == "observable" else None
            count = shift_circuit_count(circ, obs, params)
        total += count
    return total


def _commuting_count(model, circ, params, k, method) -> int | None:
    """Commuting circuits of sub-unitary ``k``, or None where the plan would take shifts."""
    if model.readout == "observable":  # the count alone, without the plan's analysis
        try:
            return commuting_gradient_count(circ, model.observable, params)
        except ValueError:
            pass  # several blocks, or none: the plan's own analysis decides below
    try:
        shared, _ = _commuting_analysis(model, circ, params, k)
    except ValueError:
        if method == "commuting":
            raise
        return None
    if method == "commuting" or _auto_prefers_commuting(model, circ, params, k, shared):
        return shared.num_gradient_circuits
    return None


@validates(
    model=Instance('qdensity.models.density:DensityQNN'),
    X=[Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), None], grad=Instance(DensityGradient),
    upstream=Array(ndim=None),
)
def chain_rule(model, X, grad: DensityGradient, upstream: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Parameter gradients of a loss from ``dL/df`` (Prop. 1 plus the mixture's vjp).

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d) or None
    grad : DensityGradient
        Its Jacobians dense or sparse (:func:`density_gradient_plan`'s ``jacobian``).
    upstream : numpy.ndarray, shape (B, m)
        ``dL / d f`` per data row and output.

    Returns
    -------
    (numpy.ndarray (P,), numpy.ndarray (M,))
        Gradients w.r.t. :attr:`DensityQNN.theta` and the mixture parameters (summed over B).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity import DensityQNN, Encoding, by_moments
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution import AdjointEngine
    >>> from qdensity.gradients import chain_rule, density_gradient_plan
    >>> model = DensityQNN(by_moments(round_robin(4)).sub_unitaries, encoding=Encoding.unary(4),
    ...                    readout="unary_probabilities", seed=0)  # K = 3 layers of 2 RBS
    >>> grad = density_gradient_plan(model, X := [[1., 2., 3., 4.]]).run(AdjointEngine())
    >>> g_theta, g_mix = chain_rule(model, X, grad, [[1., 0., 0., 0.]])  # dL / df for L = p_0
    >>> f = lambda theta: model.predict(X, theta)[0, 0]  # against central differences
    >>> fd = [(f(model.theta + s) - f(model.theta - s)) / 2e-6 for s in 1e-6 * np.eye(6)]
    >>> bool(np.allclose(g_theta, fd)), g_mix.shape  # a FixedMixture has no parameters
    (True, (0,))
    """
    upstream = np.atleast_2d(upstream)
    alpha = model.alpha(X)
    if alpha.shape[0] != upstream.shape[0]:
        alpha = np.broadcast_to(alpha, (upstream.shape[0], alpha.shape[1]))
    g_theta = np.zeros(model.num_parameters)
    for k, jac in enumerate(grad.jacobians):
        idx = model.subunitary_parameter_indices(k)
        contrib = _sparse.jacobian_vjp(jac, upstream * alpha[:, k:k + 1])
        np.add.at(g_theta, idx, contrib)
    grad_alpha = np.einsum("bm,bkm->bk", upstream, grad.outputs)
    g_mix = model.mixture.vjp(X, grad_alpha)
    return g_theta, g_mix


def _density_post(plans, bounds, K, B, sparse, results):
    """The :class:`DensityGradient` from ``results``: ``plans[:K]`` the Jacobians' (``plans[K:]``
    the forward ones), plan ``i`` reading ``results[bounds[i]:bounds[i + 1]]``."""
    jacs = [tuple(plans[k].postprocess(results[bounds[k]:bounds[k + 1]])) for k in range(K)]
    if sparse:  # parameter-shift plans answer dense: converted one sub-unitary at a time
        jacs = [_sparse.dense_to_sparse(*j) if isinstance(j[0], np.ndarray) else j for j in jacs]
    if len(plans) > K:
        outputs, errors = _forward_stack(plans[K:], bounds[K:], results)
    else:
        m = jacs[0][0].shape[0] // B if sparse else jacs[0][0].shape[1]
        outputs = errors = np.full((B, K, m), np.nan)
    return DensityGradient(outputs, errors, [v for v, _ in jacs], [e for _, e in jacs])


def _forward_stack(plans, bounds, results) -> tuple[np.ndarray, np.ndarray]:
    """The forward plans' estimates (each ``(B, m)``, plan ``i`` reading ``results[bounds[i]:
    bounds[i + 1]]``) as ``(B, K', m)`` values and errors, what ``np.stack`` of them along axis
    1 gives, each written in as soon as it is estimated: all of them held at once before a
    stack would be a second ``(B, K', m)`` pair at the peak (268 MB at ``n = 1024``, 16 rows,
    which the allocator keeps once freed)."""
    outputs = errors = np.empty(0)
    for i, plan in enumerate(plans):
        est = plan.postprocess(results[bounds[i]:bounds[i + 1]])
        value, error = np.asarray(est.value), np.asarray(est.standard_error)
        if i == 0:
            shape = (value.shape[0], len(plans)) + value.shape[1:]
            outputs, errors = np.empty(shape, value.dtype), np.empty(shape, error.dtype)
        if value.shape != outputs[:, i].shape or error.shape != value.shape:
            raise ValueError(f"forward estimate {i} has shape {value.shape}, expected "
                             f"{outputs[:, i].shape}")
        if np.result_type(outputs, value) != outputs.dtype:  # as np.stack would promote
            outputs = outputs.astype(np.result_type(outputs, value))
        if np.result_type(errors, error) != errors.dtype:
            errors = errors.astype(np.result_type(errors, error))
        outputs[:, i], errors[:, i] = value, error
        del est, value, error
    return outputs, errors
