"""The jobs and post-processing of the density-gradient plans' per-sub-unitary parts.

A sub-unitary's commuting-gradient circuit whose diagonaliser is one ``RBS(pi/4)`` layer
(every round-robin moment of the paper's classifier) and its forward circuit are
:class:`~qdensity.execution._lazy_jobs.LazyCircuitJob` s when sampled: each holds how to build
its measured circuit from the model (``job.circuit``, built on read) and the compiled
:class:`~qdensity.execution._lazy_jobs.UnaryProgram` the Hamming-weight sampler draws from,
read once off ``V(x) U_k`` (the forward program's arrays are views of the gradient
program's), so no plan holds thousands of gate-level circuits: at ``n = 1024`` those were
2,046 circuits of about 3,000 Qiskit instructions each.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from qdensity.circuits.measure import measured
from qdensity.execution._lazy_jobs import (
    LazyCircuitJob,
    SharedRows,
    UnaryProgram,
    unary_programs,
)
from qdensity.execution.plans import CircuitJob, Estimate, unary_frequencies
from qdensity.gradients import _sparse
from qdensity.gradients._circuits import gradients_from_results
from qdensity.gradients._outputs import LayerToBuild
from qdensity.gradients.diagonalising import _measured_rbs

__all__: list[str] = []


def _model_circuit(model, k: int):
    """``V(x) U_k`` (a copy), or ``U_k`` itself without an encoding (read, not changed)."""
    return model.sub_unitaries[k] if model.encoding is None else model.circuit(k)


def _jacobian_circuit(model, k: int, pairs: tuple) -> object:
    """The measured gradient circuit: ``V(x) U_k``, the ``RBS(pi/4)`` layer, measurements."""
    return _measured_rbs(_model_circuit(model, k), pairs)


def _forward_circuit(model, k: int) -> object:
    """The measured forward circuit ``V(x) U_k`` (qubit ``j`` into clbit ``j``)."""
    return measured(model.circuit(k), inplace=model.encoding is not None)


def commuting_jobs(model, k: int, circ, shared, rows, shots, prefix=None, job_rows=None
                   ) -> tuple[list[CircuitJob], UnaryProgram | None]:
    """Sub-unitary ``k``'s commuting-gradient jobs and, when they are built on read and
    sampled, the forward circuit's program (for :func:`forward_job`).

    ``shared`` is the analysis' shared estimator: its measured circuits, or a
    :class:`~qdensity.gradients._outputs.LayerToBuild` (no circuit: a lazy job, with the
    unary programs when ``shots`` is given and ``circ`` is a weight-1 RBS / FBS template;
    ``prefix``: the encoding's :class:`~qdensity.execution.samplers._hamming_compile.
    CompiledPrefix`, walked once per plan; ``job_rows``: the rows a lazy job holds, default
    ``rows``)."""
    if not isinstance(shared, LayerToBuild):
        return [CircuitJob(c, rows, shots, f"commuting_k{k}[{i}]")
                for i, c in enumerate(shared.circuits)], None
    pairs = tuple(shared.layer_pairs)
    programs = unary_programs(circ, pairs, prefix) if shots is not None else None
    job = LazyCircuitJob(partial(_jacobian_circuit, model, k, pairs), circ.num_qubits,
                         circ.num_parameters, rows if job_rows is None else job_rows, shots,
                         f"commuting_k{k}[0]",
                         programs[0] if programs else None)
    return [job], programs[1] if programs else None


def shared_loader_rows(model, circ, rows: np.ndarray, encoded: dict, loader):
    """``rows`` of ``V(x) U_k`` (``circ``) for the jobs built on read: a
    :class:`~qdensity.execution._lazy_jobs.SharedRows` holding ``V(x)``'s columns as one
    block shared by every sub-unitary of the plan, or ``rows`` itself (no encoding, no data,
    or the block not found in ``rows`` exactly).

    ``loader``: None on the first call, then what it returned: ``(block, {parameter: column of
    block})``, ``V(x)``'s ``(B, L)`` columns from :func:`~qdensity.models._rows.
    encoding_columns` (``encoded``). Returns ``(job rows, loader)``."""
    if model.encoding is None or not encoded:
        return rows, loader
    if loader is None:
        enc = list(model.encoding.circuit.parameters)
        block = np.empty((rows.shape[0], len(enc)))
        for j, p in enumerate(enc):
            block[:, j] = encoded[p]
        loader = (block, {p: j for j, p in enumerate(enc)})
    block, index = loader
    at = np.full(block.shape[1], -1, dtype=np.intp)
    for i, p in enumerate(circ.parameters):
        j = index.get(p)
        if j is not None:
            at[j] = i
    if (at < 0).any():  # V(x) not all in this circuit: its own rows
        return rows, loader
    split = SharedRows.split(rows, block, at)
    return (rows if split is None else split), loader


def forward_job(model, k: int, circ, rows, shots, program: UnaryProgram) -> LazyCircuitJob:
    """``f_k``'s sampled job, built on read, with its ``program``."""
    return LazyCircuitJob(partial(_forward_circuit, model, k), circ.num_qubits,
                          circ.num_parameters, rows, shots, f"forward_k{k}", program)


# Post-processing functions at module level, bound with functools.partial, so plans pickle.
def _shift_observable_post(inner, results):
    est = inner.postprocess(results)
    return Estimate(est.value[:, None, :], est.standard_error[:, None, :])


def _commuting_post(grads, shots, results, *, sparse: bool = False):
    if shots is not None and all(r.has_bits for r in results):
        # sampled: estimator values on the observed bits, never a 2**n array
        # (every output's table on each circuit's shots read once)
        found = gradients_from_results(grads, results, sparse=sparse)
        return found if sparse else Estimate(*found)
    probs = [r.probabilities for r in results]
    if sparse:
        return _sparse.from_probabilities(grads, probs, shots)
    if len(grads) == 1:
        val = grads[0].gradient_from_probabilities(probs)[:, None, :]
        err = (grads[0].standard_error(probs, shots)[:, None, :] if shots is not None
               else np.zeros_like(val))
        return Estimate(val, err)
    # one RBS(pi/4) layer on every pair serves every output j: the per-output estimators
    # only read the bits of their own pair, whose distribution the shared circuit reproduces
    val = np.stack([g.gradient_from_probabilities(probs) for g in grads], axis=1)
    err = (np.stack([g.standard_error(probs, shots) for g in grads], axis=1)
           if shots is not None else np.zeros_like(val))
    return Estimate(val, err)


def _forward_observable_post(inner, results):
    est = inner.postprocess(results)
    return Estimate(est.value[:, None], est.standard_error[:, None])


def _forward_unary_post(inner, unary, results):
    res = inner.postprocess(results)
    # from the observed outcomes when sampled; errors binomial over the (effective) shots, or
    # a mitigated row's delta method over its shots and the calibration
    p, _, se = unary_frequencies(res, return_std=True)
    return Estimate(p, se)
