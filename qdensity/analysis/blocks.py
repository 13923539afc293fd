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
from dataclasses import dataclass

import numpy as np
from qiskit.circuit import (
    CircuitInstruction,
    Parameter,
    ParameterExpression,
    QuantumCircuit,
)
from qiskit.quantum_info import Clifford, PauliList, SparsePauliOp

from qdensity.analysis.parameters import trainable_parameters
from qdensity.analysis.pauli import anticommutation, first_noncommuting_pair
from qdensity.analysis.structure import instruction_generator, parameter_of
from qdensity.validation import check_circuit

__all__ = ["commuting_blocks"]

_ATOL = 1e-12
_SKIP = frozenset({"barrier"})
_NON_UNITARY = frozenset({"measure", "reset", "delay"})


@dataclass
class _Trainable:
    """One trainable gate: its place, parameter, coefficient and (propagated) generator."""

    index: int
    name: str
    label: str
    parameter: Parameter
    coeff: float
    generator: SparsePauliOp


def _check_parameters(circuit: QuantumCircuit, parameters) -> list[Parameter]:
    if parameters is None:
        params = trainable_parameters(circuit)
    else:
        if isinstance(parameters, Parameter):
            parameters = [parameters]
        params = list(parameters)
        known = set(circuit.parameters)
        for p in params:
            if not isinstance(p, Parameter):
                raise TypeError(f"parameters must hold qiskit Parameters, got {p!r}")
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
        if isinstance(p, ParameterExpression) and p.parameters & params:
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


def _stacked(gens: Sequence[SparsePauliOp]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Symplectic bits of every term of every generator and where each generator starts."""
    sizes = [g.size for g in gens]
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
    x = np.concatenate([g.paulis.x for g in gens]) if gens else np.zeros((0, 0), bool)
    z = np.concatenate([g.paulis.z for g in gens]) if gens else np.zeros((0, 0), bool)
    return x, z, starts


def _span_basis(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A basis of the GF(2) span of the rows ``(x | z)``, by elimination on packed bits.

    At most ``2 n`` rows however many terms: the symplectic form is bilinear, so every pair of
    terms commutes iff every pair of basis vectors does.
    """
    n = x.shape[1]
    rows = np.packbits(np.concatenate([x, z], axis=1), axis=1)
    live = np.arange(rows.shape[0])
    basis = []
    for c in range(2 * n):
        if not live.size:
            break
        has = np.flatnonzero(rows[live, c >> 3] & (0x80 >> (c & 7)))
        if not has.size:
            continue
        pivot = live[has[0]]
        rows[live[has[1:]]] ^= rows[pivot]
        basis.append(rows[pivot])
        live = np.delete(live, has[0])
    if not basis:
        return np.zeros((0, n), bool), np.zeros((0, n), bool)
    bits = np.unpackbits(np.array(basis), axis=1, count=2 * n).astype(bool)
    return bits[:, :n], bits[:, n:]


def _first_noncommuting(gens: Sequence[SparsePauliOp]) -> tuple[int, int] | None:
    """First pair ``(a, b)``, ``a < b`` (row-major), of generators that do not commute.

    One GF(2) product gives the anticommutation of every pair of terms; summed over the terms
    of each generator it flags the pairs that *may* fail to commute (a generator pair all of
    whose terms commute does commute). Only flagged pairs get an exact commutator.
    """
    if len(gens) < 2:
        return None
    x, z, starts = _stacked(gens)
    if not anticommutation(*_span_basis(x, z)).any():  # every term commutes with every term
        return None
    anti = anticommutation(x, z).astype(np.int64)
    flags = np.add.reduceat(np.add.reduceat(anti, starts, axis=0), starts, axis=1) > 0
    for a, b in np.argwhere(np.triu(flags, k=1)):
        if not _is_zero(_commutator(gens[a], gens[b])):
            return int(a), int(b)
    return None


def _trainable_of(
    inst: CircuitInstruction, circuit: QuantumCircuit, index: int, params: set[Parameter]
) -> _Trainable:
    label = _label(inst, circuit, index)
    found = parameter_of(inst)
    if found is None or found[0] not in params:
        raise ValueError(f"gate {label} mixes trainable and other parameters; not supported")
    param, coeff = found
    op = inst.operation
    key = None
    if op.name in _CACHED_GENERATORS:
        key = (op.name, circuit.num_qubits, tuple(_qubits(inst, circuit)))
    elif (op.name == "PauliEvolution" and isinstance(getattr(op, "operator", None), SparsePauliOp)
          and op.operator.coeffs.dtype != object):
        o = op.operator  # keyed by its content: equal operators on equal qubits, one generator
        key = (op.name, circuit.num_qubits, tuple(_qubits(inst, circuit)), o.paulis.x.tobytes(),
               o.paulis.z.tobytes(), o.paulis.phase.tobytes(), o.coeffs.tobytes(), o.size)
    if key is not None:
        gen = _GENERATOR_CACHE.get(key)
        if gen is not None:
            return _Trainable(index, op.name, label, param, coeff, gen)
    try:
        gen = instruction_generator(inst, circuit)
        if gen.size > 1 or not abs(gen.coeffs[0]) > _ATOL:  # one non-zero term: already simple
            gen = gen.simplify(atol=_ATOL)
    except ValueError as exc:
        raise ValueError(f"trainable gate {label}: {exc}") from exc
    if key is not None and len(_GENERATOR_CACHE) < 100_000:
        _GENERATOR_CACHE[key] = gen
    return _Trainable(index, op.name, label, param, coeff, gen)


# Generators of the fixed-form gates depend only on (name, width, qubits); reading them once
# saves building a SparsePauliOp per gate (they are never mutated, only replaced).
_CACHED_GENERATORS = frozenset({"rx", "ry", "rz", "rxx", "ryy", "rzz", "rzx", "rbs"})
_GENERATOR_CACHE: dict[tuple, SparsePauliOp] = {}


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
    """
    live: list[_Trainable] = []
    stack = _Stack()  # every live generator's terms, propagated through the Cliffords
    for idx in range(start, stop):
        inst = circuit.data[idx]
        name = inst.operation.name
        if name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            t = _trainable_of(inst, circuit, idx, params)
            stack.append(t.generator)
            live.append(t)
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
        stack.evolve(cliff, _qubits(inst, circuit))
    if stack.evolved:  # else the generators are the ones read off the gates
        for t, gen in zip(live, stack.generators(), strict=True):
            t.generator = gen
    pair = _first_noncommuting([t.generator for t in live])
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
        self.evolved = False  # whether a Clifford has acted on the terms

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
            self.evolved = True

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

    def generators(self) -> list[SparsePauliOp]:
        paulis = self.paulis
        if paulis is None:
            return []
        coeffs = np.concatenate(self.coeffs)
        ends = np.cumsum(self.sizes)
        return [SparsePauliOp(paulis[e - k:e], coeffs[e - k:e])
                for e, k in zip(ends, self.sizes, strict=True)]


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
    >>> from qdensity.ansatze import round_robin
    >>> len(commuting_blocks(round_robin(4)))
    3
    """
    check_circuit(circuit)
    params = set(_check_parameters(circuit, parameters))
    blocks: list[tuple[int, int]] = []
    start: int | None = None
    stack = _Stack()
    for idx, inst in enumerate(circuit.data):
        if inst.operation.name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            gen = _trainable_of(inst, circuit, idx, params).generator
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
