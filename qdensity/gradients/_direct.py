"""Direct measurement of a commuting block that ends the circuit (paper Methods eq. 9, Prop. 1,
Supp. F.3; Bowles et al., Thm. 1).

For a block whose (propagated) generators ``G~_j`` commute, ``d f / d p = <psi| O_p |psi>`` with
``O_p = sum over p's gates of a i [G~, H]``. Per non-constant Pauli term of ``H`` the gradient
strings are collected (``_gradient_terms``), the terms of ``H`` are grouped greedily so that all
strings of a group commute (``_group_terms``), and each group is one measured circuit after a
diagonalising unitary, the ``RBS(pi/4)`` layer or a symplectic Clifford (``_direct_gradient``).
This is the construction behind :func:`~qdensity.gradients.commuting.commuting_gradient` and the
last block of :func:`~qdensity.gradients.blocks.commuting_block_gradient`; it lives apart from
both so that each can use it without importing the other.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.quantum_info import Clifford, PauliList, SparsePauliOp

from qdensity.analysis.blocks import (
    _ATOL,
    _evolve,
    _is_zero,
    _terms_of,
    _Trainable,
)
from qdensity.analysis.pauli import (
    anticommutation,
    diagonalising_clifford,
    first_noncommuting_pair,
)
from qdensity.gradients._circuits import _GradientCircuits
from qdensity.gradients.diagonalising import _diagonal_matrix, _measured, _rbs_layer_for
from qdensity.validation import Instance, Options, validates

__all__ = ["CommutingGradient"]


@validates(
    circuits=Instance(list), parameters=Instance(list), _values=Instance(list),
    observables=Instance(dict), term_groups=Instance(list), diagonalising_circuits=Instance(list),
    diagonal_observables=Instance(list), diagonaliser=Options(('clifford', 'rbs')),
)
@dataclass
class CommutingGradient(_GradientCircuits):
    """Circuits that yield every partial derivative of a commuting block (Methods eq. 9).

    One circuit when every gradient observable is measured after one diagonalising unitary;
    when ``H`` is a sum whose terms give non-commuting gradient terms, the terms of ``H`` are
    split into groups, one circuit each (``num_gradient_circuits`` says how many).

    Attributes
    ----------
    circuits : list of QuantumCircuit
        Input circuit + diagonalising circuit + measurement of all qubits into one register
        ``"meas"`` (clbit ``j`` = qubit ``j``); same parameters as the input.
    parameters : list of Parameter
        Differentiated parameters, in the order of the gradient's columns.
    observables : dict Parameter -> SparsePauliOp
        Gradient observable ``O_p = sum_gates a i [G~, H]`` (``d f / d p = <psi| O_p |psi>``).
    term_groups : list of list of str
        Pauli terms of ``H`` measured by each circuit.
    diagonalising_circuits : list of QuantumCircuit
    diagonal_observables : list of dict Parameter -> SparsePauliOp
        Per circuit, ``D O_p^(group) D^dagger`` (``Z``/``I`` strings only).
    diagonaliser : str
        ``"rbs"`` (a layer of ``RBS(pi/4)``, Supp. F.3) or ``"clifford"``.

    Examples
    --------
    A loader then ``RBS(t)`` give ``<Z_0> = -cos 2t``; one circuit's exact probabilities give
    the whole gradient, ``2 sin 2t``:

    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.quantum_info import SparsePauliOp, Statevector
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.gradients import commuting_gradient
    >>> qc = QuantumCircuit(2); _ = qc.x(0); qc = qc.compose(round_robin(2))
    >>> grad = commuting_gradient(qc, SparsePauliOp("IZ"))
    >>> bound = grad.circuit.remove_final_measurements(inplace=False).assign_parameters([0.3])
    >>> g = grad.gradient_from_probabilities(Statevector(bound).probabilities())
    >>> grad.num_gradient_circuits, bool(np.isclose(g[0], 2 * np.sin(0.6)))
    (1, True)
    """

    observables: dict[Parameter, SparsePauliOp] = field(default_factory=dict)
    term_groups: list[list[str]] = field(default_factory=list)
    diagonalising_circuits: list[QuantumCircuit] = field(default_factory=list)
    diagonal_observables: list[dict[Parameter, SparsePauliOp]] = field(default_factory=list)
    diagonaliser: str = "clifford"

    @property
    def circuit(self) -> QuantumCircuit:
        """The measured gradient circuit, when there is exactly one."""
        if len(self.circuits) != 1:
            raise ValueError(
                f"this gradient needs {len(self.circuits)} circuits (the observable's terms "
                "split into groups whose gradient terms commute); use .circuits"
            )
        return self.circuits[0]

    @property
    def value_matrix(self) -> np.ndarray:
        """Shape ``(2**n, P)``: each parameter's estimator on each outcome (one circuit)."""
        if len(self._values) != 1:
            raise ValueError(f"{len(self._values)} circuits; use value_matrices()")
        return self._values[0].dense()


def _gradient_terms(
    trainables: Sequence[_Trainable], observable: SparsePauliOp, params: Sequence[Parameter]
) -> tuple[dict[Parameter, SparsePauliOp], list[str], Callable[[], tuple[PauliList, list[
        tuple[str, dict[Parameter, SparsePauliOp], list[tuple[int, _Trainable]]]]]]]:
    """Total ``O_p``, the labels of the non-constant Pauli terms ``P_t`` of ``H`` and a function
    giving, per term, its share ``O_{p,t}`` with the (term, gate) origin of each Pauli string
    (built on call: only the Clifford diagonaliser needs them).

    ``i [G, h P_t] = 2 i h sum_{a: {P_a, P_t} = 0} c_a P_a P_t`` for ``G = sum_a c_a P_a``: the
    anticommuting (generator term, observable term) pairs come from one GF(2) product, their
    products from one element-wise ``PauliList.dot``; only non-zero shares are built.
    """
    n = observable.num_qubits
    zero = SparsePauliOp(PauliList.from_symplectic(np.zeros((1, n), bool),
                                                   np.zeros((1, n), bool)), [0.0])
    pl = observable.paulis
    h_all = observable.coeffs * (-1j) ** pl.phase  # to_list()'s coefficients
    sel = np.flatnonzero((pl.x.any(axis=1) | pl.z.any(axis=1)) & (np.abs(h_all) > _ATOL))
    labels = PauliList.from_symplectic(pl.z[sel], pl.x[sel]).to_labels()
    terms = list(zip(labels, h_all[sel].real, strict=True))
    if not terms or not trainables:
        return {p: zero for p in params}, labels, lambda: (
            PauliList.from_symplectic(np.zeros((1, n), bool), np.zeros((1, n), bool)),
            [(label, {p: zero for p in params}, []) for label in labels])
    ux, uz, csum, u_term, u_par, owner_of = _gradient_strings(
        trainables, PauliList.from_symplectic(pl.z[sel], pl.x[sel]), h_all[sel].real, params)

    def op(sel) -> SparsePauliOp:
        return SparsePauliOp(PauliList.from_symplectic(uz[sel], ux[sel]), csum[sel])

    def per_term() -> tuple[PauliList, list]:  # only the Clifford diagonaliser needs them
        out = []
        bounds = np.searchsorted(u_term, np.arange(len(terms) + 1))  # uniq sorted by term
        for t_idx, (label, _) in enumerate(terms):
            lo, hi = bounds[t_idx], bounds[t_idx + 1]
            shares = {p: zero for p in params}
            pb = lo + np.searchsorted(u_par[lo:hi], np.arange(len(params) + 1))
            for k in np.flatnonzero(np.diff(pb)).tolist():
                shares[params[k]] = op(slice(pb[k], pb[k + 1]))
            origin = [(r, trainables[owner_of[r]]) for r in range(lo, hi)]
            out.append((label, shares, origin))
        return PauliList.from_symplectic(uz, ux), out

    # totals: equal strings of one parameter from different terms of H add (what simplify()
    # of each parameter's terms gives, in its order: first occurrence, zeros dropped)
    pkey = np.concatenate([u_par[:, None], _packed(ux, uz)], axis=1)
    _, tfirst, tinv = np.unique(pkey, axis=0, return_index=True, return_inverse=True)
    tinv = tinv.ravel()
    tsum = (np.bincount(tinv, weights=csum.real, minlength=len(tfirst))
            + 1j * np.bincount(tinv, weights=csum.imag, minlength=len(tfirst)))
    tkeep = np.flatnonzero(np.abs(tsum) > _ATOL)
    tkeep = tkeep[np.lexsort((tfirst[tkeep], u_par[tfirst[tkeep]]))]
    rows, tpar, tcoef = tfirst[tkeep], u_par[tfirst[tkeep]], tsum[tkeep]
    total = {p: zero for p in params}
    pb = np.searchsorted(tpar, np.arange(len(params) + 1))
    for k in np.flatnonzero(np.diff(pb)).tolist():
        sel = rows[pb[k]:pb[k + 1]]
        total[params[k]] = SparsePauliOp(PauliList.from_symplectic(uz[sel], ux[sel]),
                                         tcoef[pb[k]:pb[k + 1]])
    return total, [label for label, _ in terms], per_term


def _packed(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rows of symplectic bits as int64 keys (8 bits a column), for ``np.unique(axis=0)``."""
    return np.packbits(np.concatenate([x, z], axis=1), axis=1).astype(np.int64)


def _gradient_strings(trainables: Sequence[_Trainable], hl: PauliList, hc: np.ndarray,
                      params: Sequence[Parameter]):
    """Every gradient string ``i [c P_a, h P_t]`` of the block, one row per distinct (term
    ``t``, parameter, string), sorted by term, then parameter, then string.

    Returns
    -------
    (x, z, coeffs, term, parameter, gate)
        Bits (S, n) (phase 0), complex coefficients (S,), the term's index in ``hl``, the
        parameter's column in ``params`` and the trainable gate the string first came from.
    """
    stack = _terms_of(trainables)  # every generator's terms, read once per block
    gx, gz, gph, gc, owner = stack.x, stack.z, stack.phase, stack.coeffs, stack.owner
    ia, it = np.nonzero(anticommutation(gx, gz, hl.x, hl.z))
    prod = PauliList.from_symplectic(gz[ia], gx[ia], gph[ia]).dot(hl[it])
    pcol = {p: k for k, p in enumerate(params)}
    gate_param = np.array([pcol[t.parameter] for t in trainables], dtype=np.int64)
    gate_coef = np.array([t.coeff for t in trainables])
    # i [c P_a, h P_t] = 2 i c h P_a P_t, the phase of the product absorbed, times the gate's a
    coef = (2j * gc[ia] * hc[it] * (-1j) ** prod.phase) * gate_coef[owner[ia]]
    par = gate_param[owner[ia]]
    # one entry per (term, parameter, Pauli string): coefficients of equal strings add
    keys = np.concatenate([it[:, None], par[:, None], _packed(prod.x, prod.z)], axis=1)
    uniq, first, inv = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    csum = (np.bincount(inv, weights=coef.real, minlength=len(uniq))
            + 1j * np.bincount(inv, weights=coef.imag, minlength=len(uniq)))
    keep = np.abs(csum) > _ATOL
    uniq, first, csum = uniq[keep], first[keep], csum[keep]
    return (prod.x[first], prod.z[first], csum, uniq[:, 0], uniq[:, 1], owner[ia[first]])


def _group_terms(per_term, params, merge: bool = True):
    """Greedy grouping of ``H``'s terms so that all gradient strings of a group commute.

    ``per_term``: the gradient strings (a ``PauliList``) and, per term of ``H``, its label,
    shares and the (string row, gate) origin of each string; a group's ``"strings"`` are rows.
    ``merge=False``: the groups only, their ``"ops"`` not summed (for a count).
    """
    paulis, entries = per_term
    groups: list[dict] = []
    for label, shares, origin in entries:
        strings = [r for r, _ in origin]
        if strings:
            bad = first_noncommuting_pair(paulis[strings])
            if bad is not None:
                (ra, ta), (rb, tb) = origin[bad[0]], origin[bad[1]]
                la, lb = paulis[ra].to_label(), paulis[rb].to_label()
                raise ValueError(
                    f"gradient terms for observable term {label} do not commute: {la} from "
                    f"i[G, {label}] of {ta.label} (parameter {ta.parameter}) anticommutes with "
                    f"{lb} from {tb.label} (parameter {tb.parameter}); each Pauli term of the "
                    "observable must commute or anticommute with every (propagated) generator "
                    "(Bowles et al., Thm. 1)"
                )
        for g in groups:
            if not strings or first_noncommuting_pair(paulis[g["strings"] + strings]) is None:
                g["labels"].append(label)
                g["strings"].extend(strings)
                for p in params if merge else ():
                    if not _is_zero(shares[p]):
                        g["ops"][p] = (g["ops"][p] + shares[p]).simplify(atol=_ATOL)
                break
        else:
            groups.append({"labels": [label], "strings": list(strings), "ops": dict(shares)})
    return paulis, groups


def _distinct_in_label_order(paulis: PauliList, rows: list[int]) -> PauliList:
    """The distinct strings among ``paulis[rows]``, sorted as their labels sort (what
    ``sorted(set(labels))`` gives) without making the labels: per qubit, from the last, the
    codes I < X < Y < Z."""
    x, z = paulis.x[rows], paulis.z[rows]
    code = x.astype(np.int8) + 3 * z - 2 * (x & z)  # I, X, Y, Z -> 0, 1, 2, 3
    order = np.lexsort(code.T)  # the last key (qubit n - 1, the label's first letter) leads
    code = code[order]
    keep = np.ones(len(order), dtype=bool)
    keep[1:] = np.any(code[1:] != code[:-1], axis=1)
    sel = order[keep]
    return PauliList.from_symplectic(z[sel], x[sel])


def _evolve_all(ops: dict, cliff: Clifford, n: int) -> dict:
    """``{p: C op C^dagger}``, the terms of every ``op`` evolved in one call.

    Conjugation by a Clifford permutes Pauli strings (up to sign), so an ``op`` with distinct
    strings and non-zero coefficients (every ``op`` here) stays simplified, in its order."""
    items = list(ops.items())
    if len(items) < 2:
        return {p: _evolve(op, cliff, list(range(n))).simplify(atol=_ATOL) for p, op in items}
    sizes = [op.size for _, op in items]
    paulis = PauliList.from_symplectic(
        np.concatenate([op.paulis.z for _, op in items]),
        np.concatenate([op.paulis.x for _, op in items]),
        np.concatenate([op.paulis.phase for _, op in items]),
    ).evolve(cliff, qargs=list(range(n)), frame="s")
    ends = np.cumsum(sizes)
    return {p: SparsePauliOp(paulis[e - k:e], op.coeffs)
            for (p, op), e, k in zip(items, ends, sizes, strict=True)}


_RBS_ONLY = ("diagonaliser='rbs' needs RBS trainable gates on disjoint pairs whose gradient "
             "observables the RBS(pi/4) layer diagonalises (Supp. F.3); use 'clifford' or "
             "'auto'")


def _circuit_count(trainables: Sequence[_Trainable], observable: SparsePauliOp,
                   params: Sequence[Parameter], diagonaliser: str, n: int) -> int:
    """``len(_direct_gradient(...).circuits)`` without the circuits: one when the ``RBS(pi/4)``
    layer serves (or the strings form one group), else the number of groups (same errors)."""
    total, _, per_term = _gradient_terms(trainables, observable, params)
    if diagonaliser in ("auto", "rbs") and _rbs_layer_for(trainables, total, n) is not None:
        return 1
    if diagonaliser == "rbs":
        raise ValueError(_RBS_ONLY)
    return max(1, len(_group_terms(per_term(), params, merge=False)[1]))


def _direct_gradient(
    circuit: QuantumCircuit,
    trainables: Sequence[_Trainable],
    observable: SparsePauliOp,
    params: Sequence[Parameter],
    diagonaliser: str,
) -> CommutingGradient:
    n = circuit.num_qubits
    total, all_labels, per_term = _gradient_terms(trainables, observable, params)
    if diagonaliser in ("auto", "rbs"):
        found = _rbs_layer_for(trainables, total, n)
        if found is not None:
            layer, diag = found
            return CommutingGradient(
                circuits=[_measured(circuit, layer)],
                parameters=list(params),
                _values=[_diagonal_matrix([diag[p] for p in params], n)],
                observables=total,
                term_groups=[all_labels],
                diagonalising_circuits=[layer],
                diagonal_observables=[diag],
                diagonaliser="rbs",
            )
        if diagonaliser == "rbs":
            raise ValueError(_RBS_ONLY)
    paulis, groups = _group_terms(per_term(), params)
    if not groups:  # H is a multiple of the identity: every derivative vanishes
        groups = [{"labels": [], "strings": [], "ops": dict(total)}]
    circuits, values, diag_circs, diags = [], [], [], []
    for g in groups:
        diag_circ = (
            diagonalising_clifford(_distinct_in_label_order(paulis, g["strings"]))[0]
            if g["strings"] else QuantumCircuit(n, name="diagonalise")
        )
        cliff = Clifford(diag_circ)
        diag = _evolve_all(g["ops"], cliff, n)
        circuits.append(_measured(circuit, diag_circ))
        values.append(_diagonal_matrix([diag[p] for p in params], n))
        diag_circs.append(diag_circ)
        diags.append(diag)
    return CommutingGradient(
        circuits=circuits,
        parameters=list(params),
        _values=values,
        observables=total,
        term_groups=[g["labels"] for g in groups],
        diagonalising_circuits=diag_circs,
        diagonal_observables=diags,
        diagonaliser="clifford",
    )
