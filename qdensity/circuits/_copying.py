"""Cheap copies of circuits of ``PauliEvolutionGate`` s (the equivariant models' gates).

Qiskit's ``QuantumCircuit.copy`` deep-copies every Python-side gate (``Instruction.__deepcopy__``:
a shallow copy, a deep copy of the parameter list and of the definition), about 10 us a gate:
half a second for the 43,744 gates of ``equivariant_commuting(64)``; ``assign_parameters(...,
inplace=False)`` adds a symbolic substitution per gate (about 1.5 s in all). For a
``PauliEvolutionGate`` whose definition is not built yet that deep copy is a shallow copy with its
own parameter list (Parameters and numbers are immutable and ``copy.deepcopy`` returns them as
they are); :func:`_gate_copy` makes exactly that copy without the ``copy`` module's machinery.
Every copy gets its own gate objects: sharing one between two circuits would be wrong, as
``assign_parameters(..., inplace=True)`` on one circuit rewrites the parameters of the shared
gate in both. What remains per gate is Qiskit reading the new Python gate into its circuit
(about 5 us); measured at n = 64 on a loaded 2-core box (load 1.3-2, CPU seconds):
``copy_circuit`` about 0.3 s against 0.45-0.55 s for ``QuantumCircuit.copy``, ``assign_fresh``
about 0.55 s against 1.5 s.

:func:`copy_circuit` and :func:`assign_fresh` take this path only when every instruction is
such a gate (and the circuit has no realtime variables, and for :func:`assign_fresh` a fixed
global phase and a Parameter-to-Parameter mapping); anything else goes through Qiskit.
"""

from __future__ import annotations

from collections.abc import Mapping

from qiskit.circuit import (
    CircuitInstruction,
    Parameter,
    ParameterExpression,
    QuantumCircuit,
)
from qiskit.circuit.library import PauliEvolutionGate

__all__: list[str] = []

_NUMBERS = (int, float, complex)


def _gate_copy(op: PauliEvolutionGate, params: list) -> PauliEvolutionGate:
    """What ``copy.copy(op)`` makes (``op`` has no ``__slots__`` state or copy hooks), with
    ``params`` as its own parameter list."""
    new = PauliEvolutionGate.__new__(PauliEvolutionGate)
    new.__dict__.update(op.__dict__)
    new._params = params
    return new


def _plain(op) -> bool:
    """Whether ``op`` is a ``PauliEvolutionGate`` without a definition yet."""
    return type(op) is PauliEvolutionGate and op._definition is None


def _no_vars(circuit: QuantumCircuit) -> bool:
    return not (circuit.num_vars or circuit.num_stretches)


class _NotPlain(Exception):
    """Raised inside ``map_nonstandard_ops`` by a gate :func:`copy_circuit` cannot copy."""


def copy_circuit(circuit: QuantumCircuit) -> QuantumCircuit:
    """``circuit.copy()``: the same gates on the same qubits, each its own gate object.

    A circuit of plain ``PauliEvolutionGate`` s (:func:`_plain`) is copied without copying its
    gates (``CircuitData.copy(copy_instructions=False)``: the instruction list, bits and
    parameter table), then each gate is replaced in the copy by its :func:`_gate_copy` with
    the same parameters, so the parameter table stays right; any other circuit is copied by
    ``QuantumCircuit.copy``.
    """
    if not _no_vars(circuit):
        return circuit.copy()
    seen = 0

    def own(op):
        nonlocal seen
        if not _plain(op):
            raise _NotPlain
        seen += 1
        return _gate_copy(op, list(op._params))

    try:
        data = circuit._data.copy(copy_instructions=False)
        data.map_nonstandard_ops(own)  # standard gates are skipped: counted below
    except (_NotPlain, AttributeError, TypeError):  # (the last two: another CircuitData API)
        return circuit.copy()
    if seen != len(data):
        return circuit.copy()
    cpy = circuit.copy_empty_like(vars_mode="drop")
    cpy._data = data
    return cpy


def assign_fresh(circuit: QuantumCircuit,
                 mapping: Mapping[Parameter, Parameter]) -> QuantumCircuit:
    """``circuit.assign_parameters(mapping, inplace=False)`` for a Parameter-to-Parameter
    ``mapping`` of parameters of the circuit.

    Circuits of plain ``PauliEvolutionGate`` s whose parameters are ``Parameter`` s or numbers
    get one :func:`_gate_copy` per gate with the mapped parameters, and the name Qiskit gives
    a copy (``<base name>-<count of circuits made>``); any other circuit goes through
    ``assign_parameters``.
    """
    mapping = dict(mapping)
    if (not _no_vars(circuit) or isinstance(circuit.global_phase, ParameterExpression)
            or not all(isinstance(k, Parameter) and isinstance(v, Parameter)
                       and circuit.has_parameter(k) for k, v in mapping.items())):
        return circuit.assign_parameters(mapping, inplace=False)
    get = mapping.get
    out = []
    for inst in circuit.data:
        op = inst.operation
        if not _plain(op):
            return circuit.assign_parameters(mapping, inplace=False)
        params = []
        for p in op._params:
            if isinstance(p, Parameter):
                params.append(get(p, p))
            elif isinstance(p, _NUMBERS):
                params.append(p)
            else:  # an expression (or anything else): Qiskit substitutes it
                return circuit.assign_parameters(mapping, inplace=False)
        out.append(CircuitInstruction(_gate_copy(op, params), inst.qubits, inst.clbits))
    cpy = circuit.copy_empty_like(vars_mode="drop")
    for inst in out:
        cpy._append(inst)
    cpy._increment_instances()  # as assign_parameters(inplace=False) names its copy
    cpy._name_update()
    return cpy
