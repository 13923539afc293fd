"""Commuting blocks read off a circuit (paper eq. 9, Prop. 1, Cor. 2; Methods "Commuting-block
quantum neural networks").

A *commuting block* is a run of trainable gates ``exp(-i angle G_j)`` whose generators mutually
commute (Bowles et al. 2023). Fixed Clifford gates interleaved with or following the trainable
gates are absorbed by propagating each generator to the end of its block, ``G~ = C G C^dagger``
with ``C`` the Clifford gates after the gate. This module reads the trainable gates of a circuit
and their propagated generators (``_analyse_block``), tests commutation (``_commute``) and splits
a circuit into maximal commuting blocks (:func:`commuting_blocks`); the gradient circuits built on
them live in :mod:`qdensity.gradients.commuting` and :mod:`qdensity.gradients.blocks`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import (
    CircuitInstruction,
    Parameter,
    ParameterExpression,
    QuantumCircuit,
)
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Clifford, PauliList, SparsePauliOp

from qdensity.analysis._block_terms import (
    _FIXED_FORM,
    _joined,
    _place,
    _Reader,
    _template,
    _Terms,
)
from qdensity.analysis._gf2 import all_commute
from qdensity.analysis.gate_registry import EVOLUTION, GATES
from qdensity.analysis.parameters import trainable_parameters
from qdensity.analysis.pauli import anticommutation, first_noncommuting_pair
from qdensity.validation import Circuit, Instance, SequenceOf, validates

__all__ = ["commuting_blocks"]

_ATOL = 1e-12
_SKIP = frozenset({"barrier"})
_NON_UNITARY = frozenset({"measure", "reset", "delay"})


class _Trainable:
    """One trainable gate: its place, parameter, coefficient and (propagated) generator.

    The generator is row ``row`` of a shared :class:`_Terms` stack (built on first access) or
    given outright; the label (for error messages) is built on first access.
    """

    __slots__ = ("index", "name", "parameter", "coeff", "_generator", "_terms", "_row",
                 "_circuit", "_label")

    def __init__(self, index: int, name: str, parameter: Parameter, coeff: float, *,
                 generator: SparsePauliOp | None = None, terms: _Terms | None = None,
                 row: int = 0, circuit: QuantumCircuit | None = None, label: str | None = None):
        self.index, self.name, self.parameter, self.coeff = index, name, parameter, coeff
        self._generator, self._terms, self._row = generator, terms, row
        self._circuit, self._label = circuit, label

    @property
    def label(self) -> str:
        if self._label is None:
            assert self._circuit is not None  # given whenever the label is not
            self._label = _label(self._circuit.data[self.index], self._circuit, self.index)
        return self._label

    @property
    def generator(self) -> SparsePauliOp:
        if self._generator is None:
            assert self._terms is not None  # given whenever the generator is not
            self._generator = self._terms.generator(self._row)
        return self._generator


def _terms_of(trainables: Sequence[_Trainable]) -> _Terms:
    """The generators of ``trainables`` as one stack (the block's own when they are it)."""
    if trainables:
        terms = trainables[0]._terms
        if (terms is not None and terms.num_gates == len(trainables)
                and all(t._terms is terms and t._row == i for i, t in enumerate(trainables))):
            return terms
    return _Terms.from_generators([t.generator for t in trainables])


def _check_parameters(circuit: QuantumCircuit, parameters) -> list[Parameter]:
    if parameters is None:
        params = trainable_parameters(circuit)
    else:
        if isinstance(parameters, Parameter):
            parameters = [parameters]
        params = list(parameters)
        known = set(circuit.parameters)
        for p in params:
            if p not in known:
                raise ValueError(f"parameter {p} is not a parameter of the circuit")
        if len(set(params)) != len(params):
            raise ValueError(f"parameters must not repeat, got {params}")
    if not params:
        raise ValueError(
            "no trainable parameters: the circuit has none outside the data vector 'x'"
        )
    return params


def _qubits(inst: CircuitInstruction, circuit: QuantumCircuit) -> list[int]:
    return [circuit.find_bit(q).index for q in inst.qubits]


def _label(inst: CircuitInstruction, circuit: QuantumCircuit, index: int) -> str:
    params = ", ".join(str(p) for p in inst.operation.params)
    return f"{inst.operation.name}({params}) on qubits {tuple(_qubits(inst, circuit))} [#{index}]"


def _is_trainable(inst: CircuitInstruction, params: set[Parameter]) -> bool:
    for p in inst.operation.params:
        if isinstance(p, ParameterExpression) and (
                p in params if isinstance(p, Parameter) else p.parameters & params):
            return True
    return False


def _clifford_of(inst: CircuitInstruction) -> Clifford | None:
    op = inst.operation
    if any(isinstance(p, ParameterExpression) and p.parameters for p in op.params):
        return None
    try:
        return Clifford(op)
    except Exception:  # qiskit raises QiskitError for non-Clifford gates
        return None


def _evolve(op: SparsePauliOp, cliff: Clifford, qubits: list[int]) -> SparsePauliOp:
    """``C op C^dagger`` for a Clifford ``C`` on ``qubits``."""
    paulis = op.paulis.evolve(cliff, qargs=qubits, frame="s")
    return SparsePauliOp(paulis, op.coeffs)


def _commutator(a: SparsePauliOp, b: SparsePauliOp) -> SparsePauliOp:
    return (a.dot(b) - b.dot(a)).simplify(atol=_ATOL)  # matrix product AB - BA


def _is_zero(op: SparsePauliOp) -> bool:
    return bool(np.all(np.abs(op.coeffs) <= 1e-10))


def _commute(a: SparsePauliOp, b: SparsePauliOp) -> bool:
    terms = PauliList(a.paulis) + PauliList(b.paulis)
    if first_noncommuting_pair(terms) is None:
        return True
    return _is_zero(_commutator(a, b))


def _disjoint_supports(terms: _Terms) -> bool:
    """Whether no qubit is acted on by two generators' terms (then every pair commutes: a
    moment of gates, e.g. one round-robin layer); one OR per gate, no GF(2) product."""
    sizes = np.diff(terms.starts)
    if not len(sizes) or np.any(sizes == 0):
        return False
    # bits packed 8 a byte (7x faster at 1,024 qubits): the supports are disjoint when their
    # sizes add up to the size of their union
    support = np.bitwise_or.reduceat(np.packbits(terms.x | terms.z, axis=1),
                                     terms.starts[:-1], axis=0)
    union = np.bitwise_or.reduce(support, axis=0)
    return int(np.bitwise_count(support).sum()) == int(np.bitwise_count(union).sum())


def _first_noncommuting(gens: Sequence[SparsePauliOp] | _Terms) -> tuple[int, int] | None:
    """First pair ``(a, b)``, ``a < b`` (row-major), of generators that do not commute.

    One GF(2) product gives the anticommutation of every pair of terms; summed over the terms
    of each generator it flags the pairs that *may* fail to commute (a generator pair all of
    whose terms commute does commute). Only flagged pairs get an exact commutator.
    ``gens``: the generators, or their stacked terms.
    """
    terms = gens if isinstance(gens, _Terms) else _Terms.from_generators(gens)
    if terms.num_gates < 2:
        return None
    x, z, starts = terms.x, terms.z, terms.starts[:-1]
    if _disjoint_supports(terms):  # gates on disjoint qubits (a moment) commute
        return None
    if all_commute(x, z):  # every term commutes with every term
        return None
    anti = anticommutation(x, z).astype(np.int64)
    flags = np.add.reduceat(np.add.reduceat(anti, starts, axis=0), starts, axis=1) > 0
    for a, b in np.argwhere(np.triu(flags, k=1)):
        if not _is_zero(_commutator(terms.generator(a), terms.generator(b))):
            return int(a), int(b)
    return None


def _trainable_of(
    inst: CircuitInstruction, circuit: QuantumCircuit, index: int, params: set[Parameter],
    reader: _Reader | None = None,
) -> _Trainable:
    """One trainable gate with its generator on the whole register."""
    reader = reader if reader is not None else _Reader(circuit)
    param, coeff, tpl, qubits = _read(inst, circuit, index, params, reader)
    gen = _place([tpl], [qubits], circuit.num_qubits).generator(0)
    return _Trainable(index, inst.operation.name, param, coeff, generator=gen, circuit=circuit)


def _read(inst, circuit, index, params, reader: _Reader):
    """``(parameter, coefficient, local generator template, qubit indices)`` of a gate."""
    found = reader.parameter(inst)
    if found is None or found[0] not in params:
        raise ValueError(f"gate {_label(inst, circuit, index)} mixes trainable and other "
                         "parameters; not supported")
    try:
        tpl = reader.template(inst.operation)
    except ValueError as exc:
        raise ValueError(f"trainable gate {_label(inst, circuit, index)}: {exc}") from exc
    return found[0], found[1], tpl, reader.qubits(inst)


def _check_unitary(inst: CircuitInstruction, circuit: QuantumCircuit, index: int) -> None:
    if inst.operation.name in _NON_UNITARY or not inst.qubits and inst.clbits:
        raise ValueError(
            f"circuit must be unitary (no measure/reset/delay); found "
            f"{_label(inst, circuit, index)}"
        )


def _analyse_block(
    circuit: QuantumCircuit, start: int, stop: int, params: set[Parameter]
) -> list[_Trainable]:
    """Trainable gates of ``circuit.data[start:stop]``, generators propagated to ``stop``.

    Fixed gates before the block's first trainable gate are state preparation; after it they
    must be Clifford. Generators must commute pairwise (ValueError naming both gates).
    Each gate's parameter and generator template are read once (:class:`_Reader`); the
    templates are placed on their qubits in one batch per run of gates between Cliffords.
    """
    reader = _Reader(circuit)
    n = circuit.num_qubits
    live: list[_Trainable] = []
    done: list[_Terms] = []  # the terms placed so far, propagated through the Cliffords
    tpls: list = []  # gates read since the last Clifford, not yet placed
    qubs: list[tuple[int, ...]] = []
    qindex, by_operator = reader.qindex.__getitem__, reader._by_operator
    trainable: dict[int, tuple[Parameter, bool]] = {}
    for idx, inst in enumerate(circuit.data[start:stop], start):
        op = inst.operation
        name = op.name
        if (GATES.get(name) is EVOLUTION and type(op) is PauliEvolutionGate
                and len(ps := op.params) == 1):
            # what _read gives a Pauli evolution whose time is a trainable Parameter (angle
            # 1 p + 0) and whose operator's template the reader holds, without its dispatch;
            # the gates of a class share their Parameter object, tested once
            p, o = ps[0], op.operator
            seen = trainable.get(id(p))
            if seen is None or seen[0] is not p:
                seen = trainable[id(p)] = (p, isinstance(p, Parameter) and p in params)
            hit = by_operator.get(id(o))
            if seen[1] and hit is not None and hit[0] is o:
                live.append(_Trainable(idx, name, p, 1.0, row=len(live), circuit=circuit))
                tpls.append(hit[1])
                qubs.append(tuple(map(qindex, inst.qubits)))
                continue
        if (name in _FIXED_FORM and len(ps := op.params) == 1
                and isinstance(p := ps[0], Parameter) and p in params):
            # what _read gives a fixed-form gate (RBS, RY, ...) whose angle is a trainable
            # Parameter: angle 1 p + 0, the template of its name and width
            live.append(_Trainable(idx, name, p, 1.0, row=len(live), circuit=circuit))
            tpls.append(_template(op))
            qubs.append(tuple(map(qindex, inst.qubits)))
            continue
        if name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            param, coeff, tpl, qubits = _read(inst, circuit, idx, params, reader)
            live.append(_Trainable(idx, name, param, coeff, row=len(live), circuit=circuit))
            tpls.append(tpl)
            qubs.append(qubits)
            continue
        if not live:
            continue
        cliff = _clifford_of(inst)
        if cliff is None:
            raise ValueError(
                f"gate {_label(inst, circuit, idx)} follows trainable gates of the block but is "
                "neither trainable nor Clifford; a commuting block may only be interleaved "
                "with fixed Clifford gates (use commuting_block_gradient for several blocks)"
            )
        if tpls:
            done.append(_place(tpls, qubs, n))
            tpls, qubs = [], []
        terms = _joined(done, n)
        paulis = PauliList.from_symplectic(terms.z, terms.x, terms.phase).evolve(
            cliff, qargs=reader.qubits(inst), frame="s")
        done = [_Terms(paulis.x, paulis.z, paulis.phase, terms.coeffs, terms.starts)]
    if tpls:
        done.append(_place(tpls, qubs, n))
    terms = _joined(done, n)
    for t in live:
        t._terms = terms
    pair = _first_noncommuting(terms)
    if pair is not None:
        a, b = pair
        raise ValueError(
            "generators do not commute, so these gates are not one commuting block: "
            f"{live[a].label} (parameter {live[a].parameter}) and {live[b].label} "
            f"(parameter {live[b].parameter})"
        )
    return live


class _Stack:
    """The terms of several generators as one ``PauliList``, evolved by a Clifford at once.

    Appended generators wait in a list and are joined into the ``PauliList`` only when it is
    needed (one concatenation, not one per gate)."""

    def __init__(self):
        self._paulis: PauliList | None = None
        self._pending: list[PauliList] = []
        self.coeffs: list[np.ndarray] = []
        self.sizes: list[int] = []

    @property
    def paulis(self) -> PauliList | None:
        if self._pending:
            parts = ([self._paulis] if self._paulis is not None else []) + self._pending
            self._paulis = PauliList.from_symplectic(
                np.concatenate([p.z for p in parts]), np.concatenate([p.x for p in parts]),
                np.concatenate([p.phase for p in parts]))
            self._pending = []
        return self._paulis

    def append(self, gen: SparsePauliOp) -> None:
        self._pending.append(gen.paulis)
        self.coeffs.append(gen.coeffs)
        self.sizes.append(gen.size)

    def evolve(self, cliff: Clifford, qubits: list[int]) -> None:
        if self.paulis is not None:
            self._paulis = self.paulis.evolve(cliff, qargs=qubits, frame="s")

    def commutes_with(self, gen: SparsePauliOp) -> bool:
        """Whether ``gen`` commutes with every generator: one GF(2) product against all terms,
        an exact commutator only with generators that have an anticommuting term."""
        paulis = self.paulis
        if paulis is None:
            return True
        anti = anticommutation(gen.paulis.x, gen.paulis.z, paulis.x, paulis.z)
        hit = np.flatnonzero(anti.any(axis=0))
        if not hit.size:
            return True
        ends = np.cumsum(self.sizes)
        coeffs = np.concatenate(self.coeffs)
        for owner in np.unique(np.searchsorted(ends, hit, side="right")):
            e, k = ends[owner], self.sizes[owner]
            other = SparsePauliOp(paulis[e - k:e], coeffs[e - k:e])
            if not _is_zero(_commutator(gen, other)):
                return False
        return True


@validates(
    circuit=Circuit(),
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
)
def commuting_blocks(
    circuit: QuantumCircuit, parameters: Sequence[Parameter] | None = None
) -> list[tuple[int, int]]:
    """Maximal runs of mutually commuting trainable gates (the blocks of paper eq. 9).

    Gates before the first trainable gate are state preparation. A block grows while each new
    trainable gate's generator commutes with the block's generators (propagated through the
    fixed Clifford gates in between); a non-commuting trainable gate starts a new block, a fixed
    non-Clifford gate closes the current one.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unitary circuit (no measurements).
    parameters : sequence of Parameter, optional
        Trainable parameters; default every parameter outside the vector ``"x"``.

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` ranges into ``circuit.data``; ``start`` is the block's first
        trainable gate, ``stop`` the first gate after it that belongs elsewhere.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> len(commuting_blocks(round_robin(4)))
    3
    """
    params = set(_check_parameters(circuit, parameters))
    blocks: list[tuple[int, int]] = []
    start: int | None = None
    stack = _Stack()
    reader = _Reader(circuit)
    for idx, inst in enumerate(circuit.data):
        if inst.operation.name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            gen = _trainable_of(inst, circuit, idx, params, reader).generator
            if start is not None and stack.commutes_with(gen):
                stack.append(gen)
                continue
            if start is not None:
                blocks.append((start, idx))
            start, stack = idx, _Stack()
            stack.append(gen)
            continue
        if start is None:
            continue
        cliff = _clifford_of(inst)
        if cliff is None:
            blocks.append((start, idx))
            start, stack = None, _Stack()
        else:
            stack.evolve(cliff, _qubits(inst, circuit))
    if start is not None:
        blocks.append((start, len(circuit.data)))
    if not blocks:
        raise ValueError("circuit has no trainable gates for the given parameters")
    return blocks
