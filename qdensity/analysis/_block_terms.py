"""The generator terms of many trainable gates as one stack of symplectic arrays.

The block analysis of :mod:`qdensity.analysis.blocks` reads, for every trainable gate, its
parameter, the coefficient ``a`` of its angle ``a p + b`` and its Pauli generator on the whole
register. Per gate this is cheap only if it avoids Qiskit's per-object machinery: here a gate's
generator is read once per *template* (gate name and width, or a ``PauliEvolutionGate``'s
operator) on its own qubits ``0 .. w-1`` (:func:`qdensity.analysis.instruction_generator` on a
local circuit), and the templates are placed on their qubits for all gates at once by numpy
fancy indexing (:func:`_place`). A plain :class:`~qiskit.circuit.Parameter` angle has
coefficient 1 without a symbolic gradient. :class:`_Terms` holds the result: the terms of every
gate, row-stacked, with the first row of each gate; a gate's ``SparsePauliOp`` is built only
when someone asks for it (error messages, a few exact commutators).
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
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.analysis.gate_registry import EVOLUTION, GATES
from qdensity.analysis.structure import instruction_generator, parameter_of

_ATOL = 1e-12

# Gates whose generator depends only on (name, number of qubits) (the gate registry).
_FIXED_FORM = frozenset(name for name, kind in GATES.items()
                        if kind.generator is not None and kind.fixed_generator)
_TEMPLATES: dict[tuple, SparsePauliOp] = {}  # never mutated, only replaced
_LOCAL: dict[int, QuantumCircuit] = {}


class _Terms:
    """Terms of the generators of ``G`` gates: rows ``starts[g]:starts[g + 1]`` are gate ``g``'s.

    ``x, z`` (T, n) bool, ``phase`` (T,) group phases, ``coeffs`` (T,) as in a
    ``SparsePauliOp`` whose ``paulis`` are ``PauliList.from_symplectic(z, x, phase)``.
    """

    __slots__ = ("x", "z", "phase", "coeffs", "starts")

    def __init__(self, x, z, phase, coeffs, starts):
        self.x, self.z, self.phase, self.coeffs = x, z, phase, coeffs
        self.starts = np.asarray(starts, dtype=np.intp)

    @property
    def num_gates(self) -> int:
        return len(self.starts) - 1

    @property
    def owner(self) -> np.ndarray:
        """Gate index of every row."""
        return np.repeat(np.arange(self.num_gates), np.diff(self.starts))

    def generator(self, g: int) -> SparsePauliOp:
        lo, hi = self.starts[g], self.starts[g + 1]
        return SparsePauliOp(PauliList.from_symplectic(self.z[lo:hi], self.x[lo:hi],
                                                       self.phase[lo:hi]), self.coeffs[lo:hi])

    @classmethod
    def from_generators(cls, gens: Sequence[SparsePauliOp], n: int | None = None) -> _Terms:
        starts = np.concatenate([[0], np.cumsum([g.size for g in gens])]).astype(np.intp)
        if not gens:
            w = n or 0
            return cls(np.zeros((0, w), bool), np.zeros((0, w), bool), np.zeros(0, int),
                       np.zeros(0, complex), starts)
        return cls(np.concatenate([g.paulis.x for g in gens]),
                   np.concatenate([g.paulis.z for g in gens]),
                   np.concatenate([g.paulis.phase for g in gens]),
                   np.concatenate([g.coeffs for g in gens]), starts)


def _local_circuit(width: int) -> QuantumCircuit:
    circ = _LOCAL.get(width)
    if circ is None:
        circ = _LOCAL[width] = QuantumCircuit(width)
    return circ


def _template(op) -> SparsePauliOp:
    """Generator of ``op`` on its own qubits ``0 .. w-1`` (simplified), cached per form.

    Raises ValueError (instruction_generator's message) for a gate without a known generator.
    """
    w = op.num_qubits
    key: tuple | None = None
    if op.name in _FIXED_FORM:
        key = (op.name, w)
    elif (GATES.get(op.name) is EVOLUTION
          and isinstance(getattr(op, "operator", None), SparsePauliOp)
          and op.operator.coeffs.dtype != object):
        o = op.operator  # keyed by its content: equal operators, one generator
        key = (op.name, w, o.paulis.x.tobytes(), o.paulis.z.tobytes(), o.paulis.phase.tobytes(),
               o.coeffs.tobytes(), o.size)
    if key is not None:
        gen = _TEMPLATES.get(key)
        if gen is not None:
            return gen
    local = _local_circuit(w)
    gen = instruction_generator(CircuitInstruction(op, tuple(local.qubits)), local)
    if gen.size > 1 or not abs(gen.coeffs[0]) > _ATOL:  # one non-zero term: already simple
        gen = gen.simplify(atol=_ATOL)
    if key is not None and len(_TEMPLATES) < 10_000:
        _TEMPLATES[key] = gen
    return gen


class _Reader:
    """Reads the trainable gates of one circuit: qubit indices, parameter, coefficient, template.

    Templates of ``PauliEvolutionGate`` s are also remembered per operator object (the gates of
    one class share it), so the content key is built once per operator, not once per gate.
    """

    def __init__(self, circuit: QuantumCircuit):
        self.qindex = {q: i for i, q in enumerate(circuit.qubits)}
        self._by_operator: dict[int, tuple[object, SparsePauliOp]] = {}

    def qubits(self, inst: CircuitInstruction) -> tuple[int, ...]:
        qindex = self.qindex
        return tuple(qindex[q] for q in inst.qubits)

    def parameter(self, inst: CircuitInstruction) -> tuple[Parameter, float] | None:
        """``(p, a)`` of the gate's angle ``a p + b`` (None: no free parameter)."""
        free = [p for p in inst.operation.params
                if isinstance(p, ParameterExpression) and p.parameters]
        if len(free) == 1 and isinstance(free[0], Parameter):
            return free[0], 1.0
        return parameter_of(inst)

    def template(self, op) -> SparsePauliOp:
        if GATES.get(op.name) is EVOLUTION:
            o = getattr(op, "operator", None)
            hit = self._by_operator.get(id(o))
            if hit is not None and hit[0] is o:
                return hit[1]
            gen = _template(op)
            self._by_operator[id(o)] = (o, gen)
            return gen
        return _template(op)


def _place(templates: Sequence[SparsePauliOp], qubits: Sequence[tuple[int, ...]],
           n: int) -> _Terms:
    """Each template (on qubits ``0 .. w-1``) placed on its gate's qubits of an ``n``-qubit
    register; equal templates are placed together by one fancy-indexed assignment."""
    sizes = np.fromiter((t.size for t in templates), dtype=np.intp, count=len(templates))
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.intp)
    total = int(starts[-1])
    groups: dict[int, tuple[SparsePauliOp, list[int]]] = {}
    for g, tpl in enumerate(templates):
        groups.setdefault(id(tpl), (tpl, []))[1].append(g)
    x = np.zeros((total, n), dtype=bool)
    z = np.zeros((total, n), dtype=bool)
    first = next(iter(groups.values()))[0] if groups else None
    phase = np.zeros(total, dtype=first.paulis.phase.dtype if first is not None else int)
    ctype = np.result_type(*[t.coeffs.dtype for t, _ in groups.values()]) if groups else complex
    coeffs = np.zeros(total, dtype=ctype)
    for tpl, gates in groups.values():
        s = tpl.size
        gi = np.asarray(gates, dtype=np.intp)
        rows = (starts[gi][:, None] + np.arange(s)).ravel()
        if tpl.num_qubits:
            cols = np.repeat(np.asarray([qubits[g] for g in gates], dtype=np.intp), s, axis=0)
            x[rows[:, None], cols] = np.tile(tpl.paulis.x, (len(gates), 1))
            z[rows[:, None], cols] = np.tile(tpl.paulis.z, (len(gates), 1))
        phase[rows] = np.tile(tpl.paulis.phase, len(gates))
        coeffs[rows] = np.tile(tpl.coeffs, len(gates))
    return _Terms(x, z, phase, coeffs, starts)


def _joined(parts: Sequence[_Terms], n: int) -> _Terms:
    """One stack from several, in order."""
    parts = [p for p in parts if p.num_gates]
    if not parts:
        return _Terms.from_generators([], n)
    if len(parts) == 1:
        return parts[0]
    offsets = np.cumsum([0] + [p.starts[-1] for p in parts[:-1]])
    starts = np.concatenate([[0]] + [p.starts[1:] + o for p, o in zip(parts, offsets,
                                                                       strict=True)])
    return _Terms(np.concatenate([p.x for p in parts]), np.concatenate([p.z for p in parts]),
                  np.concatenate([p.phase for p in parts]),
                  np.concatenate([p.coeffs for p in parts]), starts)
