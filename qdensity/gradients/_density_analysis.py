"""The commuting-gradient analysis of a density QNN's sub-unitary ``V(x) U_k``: gradient
observables and diagonalising circuits for the model's readout (paper Cor. 1 / Cor. 2),
derived once per structure and kept in :mod:`qdensity.gradients._analysis`'s cache, and the
choice ``method="auto"`` makes between commuting circuits and parameter shift.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.execution._compile import circuit_digest
from qdensity.gradients import _analysis
from qdensity.gradients._direct import _direct_gradient
from qdensity.gradients._outputs import rbs_output_gradients
from qdensity.gradients.commuting import (
    CommutingBlockGradient,
    _one_block,
    commuting_block_gradient,
    commuting_gradient,
)
from qdensity.gradients.shift import parameter_shift_plan


def _readout_observables(model) -> list[SparsePauliOp]:
    n = model.num_qubits
    if model.readout == "observable":
        return [model.observable]
    # unary probability p_j = <(I - Z_j)/2> on Hamming-weight-1 states
    return [SparsePauliOp.from_sparse_list([("", [], 0.5), ("Z", [j], -0.5)], n)
            for j in range(n)]


def _fingerprint_of(model, k: int, encoding_key: bytes | None = None) -> tuple:
    """The structure key of :func:`_circuit_of` ``(model, k)``: ``U_k``'s
    :func:`~qdensity.execution._compile.circuit_digest`, with the encoding's (``encoding_key``,
    taken once by the caller) when ``V(x)`` comes before it."""
    sub = circuit_digest(model.sub_unitaries[k])
    if model.encoding is None:
        return ("plain", sub)
    if encoding_key is None:
        encoding_key = circuit_digest(model.encoding.circuit)
    return ("encoded", encoding_key, sub)


def _readout_key(model) -> tuple:
    """The readout, hashable: what an analysis depends on besides the circuit."""
    if model.readout == "observable":
        obs = model.observable
        return ("observable", tuple(obs.paulis.to_labels()), obs.coeffs.tobytes())
    return (model.readout, model.num_qubits)


def _commuting_analysis(model, circ, params, k, fingerprint: tuple | None = None):
    """Gradient observables and diagonalising circuits of sub-unitary ``k``, derived once per
    structure (circuit, parameters, readout) and kept, failures too (see ``_analysis``)."""
    if fingerprint is None:
        fingerprint = _fingerprint_of(model, k)
    key = _analysis.structure_key("commuting", circ, params, _readout_key(model), fingerprint)
    return _analysis.cached(key, partial(_analyse, model, circ, params))


def _unary_terms(n: int) -> tuple[PauliList, np.ndarray]:
    """``Z_0 .. Z_{n-1}`` and the weights ``-1/2`` of the unary ``p_j = 1/2 - Z_j / 2``."""
    return (PauliList.from_symplectic(np.eye(n, dtype=bool), np.zeros((n, n), dtype=bool)),
            -0.5 * np.eye(n))


def _analyse(model, circ, params):
    if model.readout == "observable":
        try:
            grads: list = [commuting_gradient(circ, model.observable, params)]
        except ValueError as one_block:
            try:  # several commuting blocks: observable shifts (Cor. 2)
                grads = [commuting_block_gradient(circ, model.observable, None, params)]
            except ValueError:
                raise one_block from None
        return grads[0], grads
    n = model.num_qubits
    terms, weights = _unary_terms(n)
    total = SparsePauliOp(terms, np.ones(n))  # sum_j Z_j
    checked, obs, trainables = _one_block(circ, total, params, "auto")
    # one RBS(pi/4) layer: every output's table from one pass over the block's strings
    found = rbs_output_gradients(circ, trainables, terms, weights, checked, measure=False)
    if found is not None:
        return found
    shared = _direct_gradient(circ, trainables, obs, checked, "auto")
    grads = [commuting_gradient(circ, o, params) for o in _readout_observables(model)]
    same_layer = (shared.diagonaliser == "rbs" and len(shared.circuits) == 1
                  and all(g.diagonaliser == "rbs" and len(g.circuits) == 1 for g in grads))
    if not same_layer:
        raise ValueError("unary readout outputs need different diagonalising circuits")
    return shared, grads


def _auto_prefers_commuting(model, circ, params, k, gradient) -> bool:
    """``method="auto"``: one block always; several when no more circuits than parameter shift."""
    if not isinstance(gradient, CommutingBlockGradient):
        return True
    key = _analysis.structure_key("auto", circ, params, _readout_key(model))

    def decide() -> bool:
        row = np.zeros((1, circ.num_parameters))
        shift = parameter_shift_plan(circ, model.observable, row, parameters=params)
        return gradient.num_gradient_circuits <= shift.num_circuits

    return _analysis.cached(key, decide)
