"""Estimator tables of many outputs read from one RBS gradient circuit (Supp. F.3, Prop. 1).

A density QNN read out as unary probabilities ``p_j = <(I - Z_j)/2>`` has ``n`` outputs per
sub-unitary. When the sub-unitary is one moment of RBS gates on disjoint pairs, the
``RBS(pi/4)`` layer on those pairs diagonalises the gradient observables of every output at
once, so one measured circuit serves all ``n`` and each output only needs its own table of
``Z``-string coefficients. Gradient observables are linear in the observable, so the gradient
strings of every distinct term are derived once (one GF(2) product for the block), conjugated
by the layer once (:func:`qdensity.analysis._conjugate.conjugate_by_layer`) and then combined
per output with array operations: no circuit, ``SparsePauliOp`` or transfer per output.

When every output is a combination of single-qubit ``Z`` terms (the unary probabilities), the
problem is local: gate ``g`` on pair ``(a, b)`` only moves the gradients of the outputs on
``a`` and ``b``, and its gradient strings, conjugated by the layer's ``RBS(pi/4)`` on the same
pair, live on ``(a, b)``. The strings are then derived once per distinct gate (its generator
and coefficient read on its pair: one for a round-robin moment) on two qubits
(:func:`_pair_template`, the same GF(2) product and conjugation) and placed on every pair with
that gate: work linear in the width per block, where the dense ``n``-bit strings cost ``n``
times more (about 25 ms a block at ``n = 256``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import Parameter
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.analysis._conjugate import conjugate_by_layer
from qdensity.analysis.blocks import _ATOL, _terms_of, _Trainable
from qdensity.analysis.pauli import ZStringTable
from qdensity.circuits.gates import rbs_matrix
from qdensity.gradients._circuits import _GradientCircuits
from qdensity.gradients._direct import _gradient_strings, _packed
from qdensity.gradients.diagonalising import _measured, _rbs_pairs, rbs_diagonalising_layer

__all__ = ["rbs_output_tables", "rbs_output_gradients"]


def rbs_output_gradients(circuit, trainables: Sequence[_Trainable], terms: PauliList,
                         weights: np.ndarray, params: Sequence[Parameter]):
    """The one gradient circuit and per-output estimators of a block of RBS gates on disjoint
    pairs (:func:`rbs_output_tables`), or None when they do not apply.

    When every output's diagonalised gradient observables are diagonal after the
    ``RBS(pi/4)`` layer, so are those of their sum, so the layer is the block's diagonaliser
    and one measured circuit (``circuit``, the layer, measurements) serves every output; no
    ``SparsePauliOp`` per parameter is built (the whole-register analysis,
    :func:`~qdensity.gradients.commuting.commuting_gradient` on ``sum_t terms[t]``, builds two).

    Returns
    -------
    (_GradientCircuits, list of _GradientCircuits) or None
        The shared circuit with the estimator of ``d/dp sum_o output_o`` and, per output, the
        same circuit with its own table.
    """
    tables = rbs_output_tables(trainables, terms, weights, params)
    if tables is None:
        return None
    pairs = _rbs_pairs(trainables)
    assert pairs is not None  # tables are only made for such blocks
    circuits = [_measured(circuit, rbs_diagonalising_layer(circuit.num_qubits, pairs))]
    total = ZStringTable(np.concatenate([t.z for t in tables]),
                         np.concatenate([t.coefficients for t in tables]))
    return (_GradientCircuits(circuits, list(params), [total]),
            [_GradientCircuits(circuits, list(params), [t]) for t in tables])


def rbs_output_tables(trainables: Sequence[_Trainable], terms: PauliList, weights: np.ndarray,
                      params: Sequence[Parameter]) -> list[ZStringTable] | None:
    """Per output ``o = sum_t weights[o, t] terms[t] (+ a constant)``, the table of its
    diagonalised gradient observables ``D O_p^(o) D^dagger`` (one column per parameter) after
    the ``RBS(pi/4)`` layer ``D`` of the block; None when the block is not RBS gates on
    disjoint pairs or the layer leaves some output's observable off the diagonal (the caller
    then analyses the outputs one by one, which names the failure).

    Parameters
    ----------
    trainables : sequence of _Trainable
        One commuting block that ends the circuit.
    terms : PauliList, length T
        Distinct non-identity Pauli terms of the outputs.
    weights : numpy.ndarray, shape (O, T)
        Real coefficients of each output's terms.
    params : sequence of Parameter, length P

    Returns
    -------
    list of ZStringTable (O of them, P columns each) or None
    """
    pairs = _rbs_pairs(trainables)
    if pairs is None:
        return None
    weights = np.asarray(weights, dtype=float)
    local = _pairwise_tables(trainables, terms, weights, params, pairs)
    if local is not None:
        return local
    O, P = weights.shape[0], len(params)
    n = terms.num_qubits
    # every gradient string of every term with weight 1, then the layer, once
    x, z, c, term, par, _ = _gradient_strings(trainables, terms, np.ones(len(terms)), params)
    x, z, c, src = conjugate_by_layer(x, z, c, rbs_matrix(np.pi / 4), np.array(pairs))
    term, par = term[src], par[src]
    # each output's share: its weight on the string's term
    o_idx, r_idx = np.nonzero(weights[:, term])
    coef = weights[o_idx, term[r_idx]] * c[r_idx]
    keys = np.concatenate([o_idx[:, None], par[r_idx][:, None], _packed(x[r_idx], z[r_idx])],
                          axis=1)
    uniq, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    total = (np.bincount(inv, weights=coef.real, minlength=len(uniq))
             + 1j * np.bincount(inv, weights=coef.imag, minlength=len(uniq)))
    keep = np.abs(total) > _ATOL
    rows = r_idx[first[keep]]
    if x[rows].any() or np.any(np.abs(total[keep].imag) > 1e-9):
        return None
    out_o, out_p, out_c, out_z = uniq[keep, 0], uniq[keep, 1], total[keep].real, z[rows]
    # per output, its distinct Z strings (rows) and their coefficients per parameter
    zkey = np.concatenate([out_o[:, None], _packed(np.zeros_like(out_z), out_z)], axis=1)
    zuniq, zfirst, zinv = np.unique(zkey, axis=0, return_index=True, return_inverse=True)
    zinv = zinv.ravel()
    coeffs = np.zeros((len(zuniq), P))
    np.add.at(coeffs, (zinv, out_p), out_c)
    zbits = out_z[zfirst].reshape(len(zuniq), n)
    bounds = np.searchsorted(zuniq[:, 0], np.arange(O + 1))
    return [ZStringTable(zbits[bounds[o]:bounds[o + 1]], coeffs[bounds[o]:bounds[o + 1]])
            for o in range(O)]


#: Pair templates by their gate's two-qubit generator and coefficient (a pure function of the
#: key, kept across blocks and plans: every gate of a round-robin moment has the same one).
_TEMPLATES: dict = {}
_MAX_TEMPLATES = 256
_MISSING = object()

_PAIR_TERMS = PauliList.from_symplectic(np.eye(2, dtype=bool), np.zeros((2, 2), dtype=bool))


def _pair_template(x: np.ndarray, z: np.ndarray, phase: np.ndarray, coeffs: np.ndarray,
                   coeff: float) -> list[tuple[int, tuple[bool, bool], float]] | None:
    """The diagonalised gradient strings of one RBS-type gate on qubits ``(0, 1)`` (generator
    terms ``x, z, phase, coeffs`` read on its pair, angle coefficient ``coeff``) for the terms
    ``Z_0`` and ``Z_1`` with weight 1, after ``RBS(pi/4)`` on ``(0, 1)``: ``(term, z bits,
    coefficient)`` per distinct string, or None when one stays off the diagonal or complex."""
    gen = SparsePauliOp(PauliList.from_symplectic(z, x, phase), coeffs)
    gate = _Trainable(0, "rbs", Parameter("_pair"), coeff, generator=gen)
    sx, sz, c, term, _, _ = _gradient_strings([gate], _PAIR_TERMS, np.ones(2), [gate.parameter])
    sx, sz, c, src = conjugate_by_layer(sx, sz, c, rbs_matrix(np.pi / 4), np.array([(0, 1)]))
    term = term[src]
    out: dict = {}
    for t, xb, zb, v in zip(term.tolist(), map(tuple, sx.tolist()), map(tuple, sz.tolist()), c,
                            strict=True):
        out[(t, xb, zb)] = out.get((t, xb, zb), 0) + v
    strings = []
    for (t, xb, zb), v in out.items():
        if abs(v) <= _ATOL:
            continue
        if any(xb) or abs(v.imag) > 1e-9:
            return None
        strings.append((t, zb, float(v.real)))
    return strings


def _pairwise_tables(trainables: Sequence[_Trainable], terms: PauliList, weights: np.ndarray,
                     params: Sequence[Parameter],
                     pairs: Sequence[tuple[int, int]]) -> list[ZStringTable] | None:
    """:func:`rbs_output_tables` for outputs of single-qubit ``Z`` terms (on distinct qubits),
    gate by gate on its pair (``pairs[g]``, ``a < b``, from ``_rbs_pairs``) from
    :func:`_pair_template`; None when the terms are not of that kind or a template fails (the
    caller then takes the whole-register path)."""
    n = terms.num_qubits
    if terms.x.any() or np.any(terms.z.sum(axis=1) != 1):
        return None
    term_qubit = np.argmax(terms.z, axis=1)
    if len(set(term_qubit.tolist())) != len(term_qubit):
        return None
    term_at = np.full(n, -1)
    term_at[term_qubit] = np.arange(len(term_qubit))
    O, P = weights.shape[0], len(params)
    pcol = {p: k for k, p in enumerate(params)}
    w_o, w_t = np.nonzero(weights)  # each term's outputs and weights, read once
    outputs_of: list[list] = [[] for _ in range(weights.shape[1])]
    for o, t, w in zip(w_o.tolist(), w_t.tolist(), weights[w_o, w_t].tolist(), strict=True):
        outputs_of[t].append((o, w))
    stack = _terms_of(trainables)
    ab = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    on = ab[stack.owner]  # each generator term's pair
    rows = np.arange(len(on))
    lx = np.stack([stack.x[rows, on[:, 0]], stack.x[rows, on[:, 1]]], axis=1)  # (T, 2)
    lz = np.stack([stack.z[rows, on[:, 0]], stack.z[rows, on[:, 1]]], axis=1)
    templates = _TEMPLATES
    eo, eq, ecol, ev = [], [], [], []  # entries: output, Z support (a, b or -1), column, value
    for g, gate in enumerate(trainables):
        lo, hi = stack.starts[g], stack.starts[g + 1]
        ph, c = stack.phase[lo:hi], stack.coeffs[lo:hi]
        key = (lx[lo:hi].tobytes(), lz[lo:hi].tobytes(), ph.tobytes(), c.tobytes(), gate.coeff)
        strings = templates.get(key, _MISSING)
        if strings is _MISSING:
            strings = templates[key] = _pair_template(lx[lo:hi], lz[lo:hi], ph, c, gate.coeff)
            while len(templates) > _MAX_TEMPLATES:
                templates.pop(next(iter(templates)))
        if strings is None:
            return None
        col = pcol[gate.parameter]
        a, b = int(ab[g, 0]), int(ab[g, 1])
        for local, zb, v in strings:
            t = int(term_at[(a, b)[local]])
            if t < 0:
                continue
            support = (a if zb[0] else -1, b if zb[1] else -1)
            for o, w in outputs_of[t]:
                eo.append(o)
                eq.append(support)
                ecol.append(col)
                ev.append(w * v)
    keys = np.concatenate([np.array(eo, dtype=np.intp).reshape(-1, 1),
                           np.array(eq, dtype=np.intp).reshape(-1, 2)], axis=1)
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    coeffs = np.zeros((len(uniq), P))
    np.add.at(coeffs, (inv.ravel(), np.array(ecol, dtype=np.intp)), np.array(ev, dtype=float))
    coeffs[np.abs(coeffs) <= _ATOL] = 0.0
    keep = coeffs.any(axis=1)
    uniq, coeffs = uniq[keep], coeffs[keep]
    zbits = np.zeros((len(uniq), n), dtype=bool)
    for j in (1, 2):
        on_q = uniq[:, j] >= 0
        zbits[np.flatnonzero(on_q), uniq[on_q, j]] = True
    bounds = np.searchsorted(uniq[:, 0], np.arange(O + 1))
    return [ZStringTable(zbits[bounds[o]:bounds[o + 1]], coeffs[bounds[o]:bounds[o + 1]])
            for o in range(O)]
