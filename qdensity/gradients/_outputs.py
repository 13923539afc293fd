"""Estimator tables of many outputs read from one RBS gradient circuit (Supp. F.3, Prop. 1).

A density QNN read out as unary probabilities ``p_j = <(I - Z_j)/2>`` has ``n`` outputs per
sub-unitary. When the sub-unitary is one moment of RBS gates on disjoint pairs, the
``RBS(pi/4)`` layer on those pairs diagonalises the gradient observables of every output at
once, so one measured circuit serves all ``n`` and each output only needs its own table of
``Z``-string coefficients. Gradient observables are linear in the observable, so the gradient
strings of every distinct term are derived once (one GF(2) product for the block), conjugated
by the layer once (:func:`qdensity.analysis._conjugate.conjugate_by_layer`) and then combined
per output with array operations: no circuit, ``SparsePauliOp`` or transfer per output.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import Parameter
from qiskit.quantum_info import PauliList

from qdensity.analysis._conjugate import conjugate_by_layer
from qdensity.analysis.blocks import _ATOL, _Trainable
from qdensity.analysis.pauli import ZStringTable
from qdensity.circuits.gates import rbs_matrix
from qdensity.gradients._direct import _gradient_strings, _packed
from qdensity.gradients.diagonalising import _rbs_pairs

__all__ = ["rbs_output_tables"]


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
