"""Building circuits from other circuits' instructions, on public Qiskit API only.

The plans of a density QNN put the same gates into many circuits: ``V(x) U_k`` for every
sub-unitary ``k``, its measured forward circuit, its gradient circuit (``V(x) U_k`` followed by
a diagonalising layer). Qiskit's general tools are slow for that: ``QuantumCircuit.compose``
costs about 11-15 us a gate (it remaps bits and variables per instruction and copies every
gate), ``QuantumCircuit.append`` about 10-15 us (argument broadcasting and checks), against
about 4 us a gate for ``QuantumCircuit.copy`` and 1.5-2 us for ``QuantumCircuit._append``,
Qiskit's documented unchecked fast path, of an instruction on bits the circuit already has
(measured with Qiskit 2.6 on circuits of ``RBSGate`` s).

Ownership follows ``QuantumCircuit.append(..., copy=True)``: a gate holding symbolic parameters
is copied (``Instruction.copy``) before it goes into another circuit, so
``assign_parameters(..., inplace=True)`` on one circuit never rewrites another's gates; a gate
without symbolic parameters (``RBS(pi/4)``, ``X``, measurements) is shared, as Qiskit shares it.

* :func:`extend` appends a circuit's instructions to another (``compose(..., inplace=True)``
  for circuits without classical bits or variables), :func:`concatenate` is
  ``first.compose(second)``;
* :func:`append_owned` appends instructions already on a circuit's bits (a split of a circuit
  into parts, :func:`qdensity.models.decompositions.by_moments`);
* :func:`fresh_gate` is a gate with new parameters, sharing nothing mutable with its template
  (the equivariant models' ``PauliEvolutionGate`` s, one per Pauli string);
* :func:`assign_fresh` renames parameters (``assign_parameters(..., inplace=False)``);
* :func:`gc_paused` holds Python's cyclic garbage collector off while many circuits are built.
"""

from __future__ import annotations

import copy
import gc
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager

from qiskit.circuit import (
    CircuitInstruction,
    Instruction,
    Parameter,
    ParameterExpression,
    QuantumCircuit,
)

__all__: list[str] = []


def _symbolic(op: Instruction) -> bool:
    """Whether a gate holds a symbolic parameter (then a copy goes into another circuit)."""
    for p in op.params:  # a loop, not any(...): called once per gate of every copy
        if isinstance(p, ParameterExpression):
            return True
    return False


def _owned(op: Instruction) -> Instruction:
    """``op`` as ``QuantumCircuit.append(op, ..., copy=True)`` would store it."""
    return op.copy() if _symbolic(op) else op


def _plain(circuit: QuantumCircuit) -> bool:
    """No classical bits and no realtime variables: instructions carry over by qubit alone."""
    return not (circuit.num_clbits or circuit.num_vars or circuit.num_stretches)


def empty_like(circuit: QuantumCircuit, name: str | None = None) -> QuantumCircuit:
    """``circuit.copy_empty_like(name)``: the same registers and bits, global phase and
    metadata, no instructions.

    A circuit whose bits are exactly those of its registers (and has no variables or layout)
    is made by the ``QuantumCircuit`` constructor from its registers: ``copy_empty_like`` of
    a large circuit, or a copy of such an empty copy, takes milliseconds (0.5-4 ms at 32,640
    gates), the constructor tens of microseconds.
    """
    regs = [*circuit.qregs, *circuit.cregs]
    if (not _plain_vars(circuit) or circuit.layout is not None
            or list(circuit.qubits) != [b for r in circuit.qregs for b in r]
            or list(circuit.clbits) != [b for r in circuit.cregs for b in r]):
        return circuit.copy_empty_like(name)
    return QuantumCircuit(*regs, name=circuit.name if name is None else name,
                          global_phase=circuit.global_phase,
                          metadata=copy.deepcopy(circuit.metadata))


def _plain_vars(circuit: QuantumCircuit) -> bool:
    return not (circuit.num_vars or circuit.num_stretches)


def append_owned(out: QuantumCircuit, instructions: Iterable[CircuitInstruction], *,
                 new: bool = False) -> None:
    """Append ``instructions`` (on bits of ``out``: taken from a circuit ``out`` was made from
    with ``copy_empty_like``, or made for it) to ``out`` in place, each symbolic gate copied.

    Parameters
    ----------
    out : QuantumCircuit
        Modified in place.
    instructions : iterable of CircuitInstruction
        Valid on ``out``'s bits (unchecked: Qiskit's ``_append``).
    new : bool
        The gates were made for ``out`` (in no other circuit): appended as they are.
    """
    if new:
        for inst in instructions:
            out._append(inst)
        return
    for inst in instructions:
        op = inst.operation
        out._append(inst.replace(operation=op.copy()) if _symbolic(op) else inst)


def extend(out: QuantumCircuit, other: QuantumCircuit,
           qubits: Sequence[int] | None = None) -> QuantumCircuit:
    """``out.compose(other, qubits=qubits, inplace=True)``, returning ``out``.

    Every instruction of ``other`` is appended on ``out.qubits[qubits[i]]`` for ``other``'s
    qubit ``i`` (``qubits`` defaults to ``0 .. other.num_qubits - 1``), symbolic gates copied,
    and ``other``'s global phase is added. A circuit with classical bits or realtime variables
    goes through ``compose`` itself.

    Parameters
    ----------
    out : QuantumCircuit
        Modified in place (and returned).
    other : QuantumCircuit
        At most ``out.num_qubits`` qubits.
    qubits : sequence of int, optional
        Qubits of ``out`` that ``other``'s qubits land on.

    Returns
    -------
    QuantumCircuit
        ``out``.
    """
    if not (_plain(other) and _plain(out)):
        out.compose(other, qubits=qubits, inplace=True)
        return out
    targets = out.qubits
    where = (dict(zip(other.qubits, targets, strict=False)) if qubits is None
             else {q: targets[j] for q, j in zip(other.qubits, qubits, strict=True)})
    if len(where) != other.num_qubits:
        raise ValueError(f"cannot put {other.num_qubits} qubits onto a {out.num_qubits}-qubit "
                         "circuit")
    for inst in other.data:
        op = inst.operation
        out._append(CircuitInstruction(op.copy() if _symbolic(op) else op,
                                       tuple([where[q] for q in inst.qubits])))
    if other.global_phase != 0:
        out.global_phase = out.global_phase + other.global_phase
    return out


def concatenate(first: QuantumCircuit, second: QuantumCircuit) -> QuantumCircuit:
    """``first.compose(second)``: a copy of ``first`` (its name and metadata) followed by
    ``second`` on its first qubits, sharing no symbolic gate with either."""
    return extend(first.copy(), second)


def concatenated_view(first: QuantumCircuit, second: QuantumCircuit) -> QuantumCircuit:
    """:func:`concatenate` ``(first, second)`` sharing the gate objects of both: a read-only
    view (for analyses and compilation that only read it; never bound, assigned or handed to
    a job), without copying a symbolic gate (at ``n = 1024`` the copy is about 40 ms of a
    1,500-gate ``V(x) U_k``). Circuits with classical bits or variables are copied as
    :func:`concatenate` does."""
    if not (_plain(first) and _plain(second)) or second.num_qubits > first.num_qubits:
        return concatenate(first, second)
    out = empty_like(first)
    for inst in first.data:
        out._append(inst)
    where = dict(zip(second.qubits, out.qubits, strict=False))
    for inst in second.data:
        out._append(CircuitInstruction(inst.operation, tuple([where[q] for q in inst.qubits])))
    if second.global_phase != 0:
        out.global_phase = out.global_phase + second.global_phase
    return out


_OBJECT_REDUCE_EX: object = object.__reduce_ex__
_OBJECT_REDUCE: object = object.__reduce__


def fresh_gate(template: Instruction, params: list) -> Instruction:
    """A shallow copy of ``template`` with its own parameter list ``params``.

    For gates whose definition is derived from their parameters (``PauliEvolutionGate``,
    :class:`~qdensity.circuits.gates.RBSGate`): the definition is dropped (``definition =
    None``), so it is built again from ``params`` when asked for; the other attributes (the
    operator of a Pauli evolution: immutable) are shared. About a tenth of the cost of a new
    ``PauliEvolutionGate``.

    Parameters
    ----------
    template : Instruction
    params : list
        The new gate's parameters (validated by the gate's ``params`` setter).

    Returns
    -------
    Instruction
    """
    cls = type(template)
    reduce_ex: object = cls.__reduce_ex__
    reduce: object = cls.__reduce__
    if (getattr(cls, "__copy__", None) is None and reduce_ex is _OBJECT_REDUCE_EX
            and reduce is _OBJECT_REDUCE):
        # what copy.copy does for such a class, without its reduce/reconstruct round trip
        new = object.__new__(cls)
        new.__dict__.update(template.__dict__)
    else:
        new = copy.copy(template)
    new.params = params  # the setter builds a new list: nothing shared with the template
    new.definition = None
    return new


def assign_fresh(circuit: QuantumCircuit,
                 mapping: Mapping[Parameter, Parameter]) -> QuantumCircuit:
    """``circuit.assign_parameters(mapping, inplace=False)`` for a Parameter-to-Parameter
    ``mapping`` of parameters of the circuit (the copy keeps ``circuit``'s name)."""
    out = circuit.assign_parameters(dict(mapping), inplace=False, flat_input=True)
    out.name = circuit.name
    return out


@contextmanager
def gc_paused() -> Iterator[None]:
    """Python's cyclic garbage collector held off for a bulk build of circuits.

    Building hundreds of thousands of gates (a density QNN's gradient plan at ``n = 256``
    holds about 360,000) allocates millions of container objects, so the collector runs
    thousands of times and each older-generation pass traverses every gate built so far,
    although the build makes no garbage cycles: about a tenth of the build's CPU time.
    Collection resumes on exit (when it was enabled on entry; nested uses keep it off until
    the outermost ends), and anything left to collect is collected then as usual.
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
