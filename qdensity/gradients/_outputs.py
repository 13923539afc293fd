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
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from qiskit.circuit import Parameter
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.analysis._conjugate import conjugate_by_layer
from qdensity.analysis.blocks import _ATOL, _terms_of, _Trainable
from qdensity.analysis.gate_registry import RBS
from qdensity.analysis.pauli import ZStringTable
from qdensity.circuits.gates import rbs_matrix
from qdensity.gradients._circuits import _GradientCircuits
from qdensity.gradients._direct import _gradient_strings, _packed
from qdensity.gradients.diagonalising import _measured_rbs, _rbs_pairs

__all__ = ["rbs_output_tables", "rbs_output_gradients", "OutputTables", "OutputGradients"]


def rbs_output_gradients(circuit, trainables: Sequence[_Trainable], terms: PauliList,
                         weights: np.ndarray, params: Sequence[Parameter], *,
                         measure: bool = True):
    """The one gradient circuit and per-output estimators of a block of RBS gates on disjoint
    pairs (:func:`rbs_output_tables`), or None when they do not apply.

    When every output's diagonalised gradient observables are diagonal after the
    ``RBS(pi/4)`` layer, so are those of their sum, so the layer is the block's diagonaliser
    and one measured circuit (``circuit``, the layer, measurements) serves every output; no
    ``SparsePauliOp`` per parameter is built (the whole-register analysis,
    :func:`~qdensity.gradients.commuting.commuting_gradient` on ``sum_t terms[t]``, builds two).

    ``measure=False`` builds no circuit: the shared object's ``circuits`` are empty and its
    ``layer_pairs`` name the layer, for the caller to build the measured circuit on read.

    Returns
    -------
    (_GradientCircuits, list of _GradientCircuits) or None
        The shared circuit with the estimator of ``d/dp sum_o output_o`` and, per output, the
        same circuit with its own table.
    """
    pairs = _rbs_pairs(trainables)
    if pairs is None:
        return None
    tables = _tables_on(trainables, terms, weights, params, pairs)
    if tables is None:
        return None
    circuits = [_measured_rbs(circuit, pairs)] if measure else []
    shared = (partial(_GradientCircuits, circuits) if measure
              else partial(LayerToBuild, circuits, layer_pairs=list(pairs)))
    names = list(params)  # one list for the block's outputs (read only), not one each
    if isinstance(tables, OutputTables):
        return (shared(list(params), _Whole(tables)),
                OutputGradients(circuits, names, tables, None if measure else list(pairs)))
    total = _whole(tables)
    return (shared(list(params), [total]), [shared(names, [t]) for t in tables])


@dataclass
class LayerToBuild(_GradientCircuits):
    """A block's estimators whose one measured circuit (the block's circuit, an ``RBS(pi/4)``
    layer on ``layer_pairs``, measurements) is left to the caller to build on read:
    ``circuits`` is empty and the analysis holds no circuit."""

    layer_pairs: list[tuple[int, int]] = field(default_factory=list)

    @property
    def num_gradient_circuits(self) -> int:
        """One circuit per data point (not built here)."""
        return 1


class OutputTables(Sequence):
    """The per-output tables of one block of RBS gates on pairs, held as one compact stack.

    Output ``o``'s strings are rows ``bounds[o]:bounds[o + 1]``; a string has ``Z`` on at
    most two qubits (``support[r]``, ``-1`` for none) and its coefficients are given by their
    nonzeros (``entry_string``, ``entry_column``, ``entry_value``). A unary output of a
    round-robin moment weighs on one or two of the ``P`` columns, so the dense ``(strings,
    n)`` bits and ``(strings, P)`` coefficients would be almost all zeros: 167 MB over the
    round-robin model at ``n = 256``, about 10 GB at ``n = 1024``. Indexing gives output
    ``o``'s :class:`~qdensity.analysis.pauli.ZStringTable`, built on read;
    :meth:`strings` and :meth:`entries` give every output's at once, by their nonzeros
    (:func:`qdensity.gradients._circuits.gradients_from_results` reads those).
    """

    def __init__(self, num_qubits: int, num_columns: int, bounds: np.ndarray,
                 support: np.ndarray, entry_string: np.ndarray, entry_column: np.ndarray,
                 entry_value: np.ndarray) -> None:
        self.num_qubits, self.num_columns = int(num_qubits), int(num_columns)
        self.bounds = np.asarray(bounds, dtype=np.int64)
        small = np.int32 if max(self.num_qubits, self.num_columns) < 2**31 else np.int64
        self.support = np.asarray(support).astype(small)
        self.entry_string = np.asarray(entry_string).astype(np.int64)
        self.entry_column = np.asarray(entry_column).astype(small)
        self.entry_value = np.asarray(entry_value, dtype=float)

    def __len__(self) -> int:
        return self.bounds.size - 1

    @property
    def num_strings(self) -> int:
        """Strings of every output together."""
        return int(self.bounds[-1])

    def __getitem__(self, o):
        if isinstance(o, slice):
            return [self[i] for i in range(*o.indices(len(self)))]
        o = range(len(self))[o]  # negative indices; IndexError past the end
        lo, hi = int(self.bounds[o]), int(self.bounds[o + 1])
        return self._table(lo, hi)

    def whole(self) -> ZStringTable:
        """Every output's strings in one table (the sum's estimator), built on read."""
        return self._table(0, self.num_strings)

    def _table(self, lo: int, hi: int) -> ZStringTable:
        z = np.zeros((hi - lo, self.num_qubits), dtype=bool)
        for j in (0, 1):
            q = self.support[lo:hi, j]
            on = np.flatnonzero(q >= 0)
            z[on, q[on]] = True
        a, b = np.searchsorted(self.entry_string, (lo, hi))
        coeffs = np.zeros((hi - lo, self.num_columns))
        np.add.at(coeffs, (self.entry_string[a:b] - lo, self.entry_column[a:b]),
                  self.entry_value[a:b])
        return ZStringTable(z, coeffs)

    def strings(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        """``(z_row, z_col, num_strings, num_qubits)``: the set ``Z`` bits of every string."""
        rows, j = np.nonzero(self.support >= 0)
        return rows, self.support[rows, j].astype(np.int64), self.num_strings, self.num_qubits

    def entries(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(string, column, value)`` with ``column = o * num_columns + p`` for output ``o``'s
        estimator of parameter ``p`` (the layout of ``len(self)`` stacked outputs)."""
        output = np.searchsorted(self.bounds, self.entry_string, side="right") - 1
        return (self.entry_string,
                output * self.num_columns + self.entry_column.astype(np.int64),
                self.entry_value)


class _Whole(Sequence):
    """One table, the sum's (:meth:`OutputTables.whole`), built on read: a
    ``_GradientCircuits``'s ``_values``."""

    def __init__(self, tables: OutputTables) -> None:
        self.tables = tables

    def __len__(self) -> int:
        return 1

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(1))]
        range(1)[i]  # IndexError past the end
        return self.tables.whole()


class OutputGradients(Sequence):
    """Per output, the block's shared measured circuits with that output's table (a
    ``_GradientCircuits`` built on read from :class:`OutputTables`): ``n`` objects a block
    are never held (about a million over the round-robin model at ``n = 1024``)."""

    def __init__(self, circuits: list, parameters: list, tables: OutputTables,
                 layer_pairs: list | None = None) -> None:
        self.circuits, self.parameters, self.tables = circuits, parameters, tables
        self.layer_pairs = layer_pairs  # the circuit left to build (LayerToBuild), or None

    def __len__(self) -> int:
        return len(self.tables)

    def __getitem__(self, o):
        if isinstance(o, slice):
            return [self[i] for i in range(*o.indices(len(self)))]
        if self.layer_pairs is not None:
            return LayerToBuild(self.circuits, self.parameters, [self.tables[o]],
                                layer_pairs=self.layer_pairs)
        return _GradientCircuits(self.circuits, self.parameters, [self.tables[o]])


def _whole(tables: Sequence[ZStringTable]) -> ZStringTable:
    """The sum's table: every output's strings, in order. The outputs' tables are consecutive
    row slices of one stacked pair of arrays, which is then the sum's table itself (no copy:
    at n = 256 a copy is 160 MB over the round-robin model); otherwise concatenated."""
    z0, c0 = tables[0].z, tables[0].coefficients
    zb, cb = z0.base, c0.base
    rows = sum(t.z.shape[0] for t in tables)
    if (isinstance(zb, np.ndarray) and isinstance(cb, np.ndarray) and zb.ndim == cb.ndim == 2
            and zb.shape == (rows, z0.shape[1]) and cb.shape == (rows, c0.shape[1])
            and zb.dtype == bool and cb.dtype == float):
        start, consecutive = 0, True
        for t in tables:
            consecutive = (t.z.base is zb and t.coefficients.base is cb
                           and _offset(t.z, zb) == start * zb.strides[0]
                           and _offset(t.coefficients, cb) == start * cb.strides[0])
            if not consecutive:
                break
            start += t.z.shape[0]
        if consecutive:
            return ZStringTable(zb, cb)
    return ZStringTable(np.concatenate([t.z for t in tables]),
                        np.concatenate([t.coefficients for t in tables]))


def _offset(view: np.ndarray, base: np.ndarray) -> int:
    """Bytes from ``base``'s first element to ``view``'s."""
    return view.__array_interface__["data"][0] - base.__array_interface__["data"][0]


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
    tables = _tables_on(trainables, terms, weights, params, pairs)
    return None if tables is None else list(tables)


def _tables_on(trainables: Sequence[_Trainable], terms: PauliList, weights: np.ndarray,
               params: Sequence[Parameter],
               pairs: list[tuple[int, int]]) -> Sequence[ZStringTable] | None:
    """:func:`rbs_output_tables` on the block's pairs (``_rbs_pairs(trainables)``, not None)."""
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
    gate = _Trainable(0, RBS.name, Parameter("_pair"), coeff, generator=gen)
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


def _templates_of(trainables: Sequence[_Trainable], stack, ab: np.ndarray):
    """Per gate, the index of its pair template (:func:`_pair_template`, read on its pair
    ``ab[g]``) in the returned list of templates; ``(tid, None)`` when one fails. Gates whose
    generators have as many terms are keyed at once (one ``np.unique`` over their bytes), else
    one by one."""
    G = len(trainables)
    rows = np.arange(stack.x.shape[0])
    on = ab[stack.owner]  # each generator term's pair
    lx = np.stack([stack.x[rows, on[:, 0]], stack.x[rows, on[:, 1]]], axis=1)  # (T, 2)
    lz = np.stack([stack.z[rows, on[:, 0]], stack.z[rows, on[:, 1]]], axis=1)
    ph = np.asarray(stack.phase, dtype=np.int64)
    c = np.asarray(stack.coeffs, dtype=complex)
    coeff = np.array([t.coeff for t in trainables], dtype=float)
    sizes = np.diff(stack.starts)
    if G and np.all(sizes == sizes[0]) and sizes[0] > 0:
        m = int(sizes[0])
        raw = np.concatenate([
            lx.reshape(G, 2 * m).astype(np.uint8), lz.reshape(G, 2 * m).astype(np.uint8),
            ph.reshape(G, m).view(np.uint8).reshape(G, -1),
            c.reshape(G, m).view(np.uint8).reshape(G, -1),
            coeff.reshape(G, 1).view(np.uint8).reshape(G, -1)], axis=1)
        if (raw == raw[0]).all():  # one template (a round-robin moment): no sort
            firsts, tid = np.zeros(1, dtype=np.intp), np.zeros(G, dtype=np.intp)
        else:
            _, firsts, tid = np.unique(raw, axis=0, return_index=True, return_inverse=True)
            tid = tid.ravel()
    else:
        seen: dict = {}
        tid = np.empty(G, dtype=np.intp)
        for g in range(G):
            lo, hi = stack.starts[g], stack.starts[g + 1]
            key = (lx[lo:hi].tobytes(), lz[lo:hi].tobytes(), ph[lo:hi].tobytes(),
                   c[lo:hi].tobytes(), float(coeff[g]))
            tid[g] = seen.setdefault(key, len(seen))
        firsts = np.unique(tid, return_index=True)[1]
    strings = []
    for g in firsts.tolist():
        lo, hi = stack.starts[g], stack.starts[g + 1]
        key = (lx[lo:hi].tobytes(), lz[lo:hi].tobytes(), stack.phase[lo:hi].tobytes(),
               stack.coeffs[lo:hi].tobytes(), trainables[g].coeff)
        found = _TEMPLATES.get(key, _MISSING)
        if found is _MISSING:
            found = _TEMPLATES[key] = _pair_template(lx[lo:hi], lz[lo:hi], stack.phase[lo:hi],
                                                     stack.coeffs[lo:hi], trainables[g].coeff)
            while len(_TEMPLATES) > _MAX_TEMPLATES:
                _TEMPLATES.pop(next(iter(_TEMPLATES)))
        if found is None:
            return tid, None
        strings.append(found)
    return tid, strings


def _pairwise_tables(trainables: Sequence[_Trainable], terms: PauliList, weights: np.ndarray,
                     params: Sequence[Parameter],
                     pairs: Sequence[tuple[int, int]]) -> OutputTables | None:
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
    stack = _terms_of(trainables)
    ab = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    if ab.shape[0] != len(trainables):  # two gates on one pair: no pair per gate, general path
        return None
    tid, strings = _templates_of(trainables, stack, ab)
    if strings is None:
        return None
    # one entry per (gate, template string, output of the string's term), in that order (the
    # order of the sums below): output, Z support (a, b or -1), column, value
    count = np.array([len(s) for s in strings], dtype=np.intp)
    flat = [(local, zb[0], zb[1], v) for s in strings for local, zb, v in s]
    s_local, s_za, s_zb = (np.array([f[i] for f in flat], dtype=np.intp).reshape(-1)
                           for i in range(3))
    s_val = np.array([f[3] for f in flat], dtype=float).reshape(-1)
    per_gate = count[tid]
    gate = np.repeat(np.arange(len(tid)), per_gate)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.intp)
    row = np.repeat(first[tid], per_gate) + (np.arange(len(gate))
                                              - np.repeat(np.cumsum(per_gate) - per_gate,
                                                          per_gate))
    qubit = ab[gate, s_local[row]]
    term = term_at[qubit]
    on = term >= 0
    gate, row, term = gate[on], row[on], term[on]
    a, b = ab[gate, 0], ab[gate, 1]
    support = np.stack([np.where(s_za[row] == 1, a, -1), np.where(s_zb[row] == 1, b, -1)],
                       axis=1)
    # each term's outputs and weights (in output order), expanded per entry
    w_o, w_t = np.nonzero(weights)
    by_term = np.argsort(w_t, kind="stable")
    w_o, w_v = w_o[by_term], weights[w_o[by_term], w_t[by_term]]
    n_out = np.bincount(w_t, minlength=weights.shape[1])
    o_first = np.concatenate([[0], np.cumsum(n_out)[:-1]]).astype(np.intp)
    reps = n_out[term]
    entry = np.repeat(np.arange(len(term)), reps)
    pos = np.repeat(o_first[term], reps) + (np.arange(len(entry))
                                            - np.repeat(np.cumsum(reps) - reps, reps))
    cols = np.array([pcol[t.parameter] for t in trainables], dtype=np.intp)
    eo, ecol, ev = w_o[pos], cols[gate[entry]], w_v[pos] * s_val[row[entry]]
    # (output, a + 1, b + 1) as one integer in base n + 1: its order is the rows' order
    base = n + 1
    flat_key = (eo.astype(np.int64) * base + (support[entry, 0] + 1)) * base \
        + (support[entry, 1] + 1)
    ukey, inv = np.unique(flat_key, return_inverse=True)
    # the coefficients by their nonzeros (string, column): never a dense (strings, P) table
    entry_key = inv.ravel().astype(np.int64) * P + ecol
    ekey, einv = np.unique(entry_key, return_inverse=True)
    value = np.bincount(einv.ravel(), weights=ev, minlength=ekey.size)
    big = np.abs(value) > _ATOL
    ekey, value = ekey[big], value[big]
    string, column = ekey // P, ekey % P
    kept = np.unique(string)  # strings with a coefficient left
    uniq = np.stack([ukey // (base * base), ukey // base % base - 1, ukey % base - 1],
                    axis=1)[kept]
    bounds = np.searchsorted(uniq[:, 0], np.arange(O + 1))
    return OutputTables(n, P, bounds, uniq[:, 1:], np.searchsorted(kept, string), column,
                        value)
