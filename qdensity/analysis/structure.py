"""Structure read off circuits: moments, Pauli generators, Hamming-weight preservation.

Builders never keep a parallel list of layers; everything structural is derived here from the
gates themselves (docs/design.md, "The spine": structure is derived, not duplicated).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import CircuitInstruction, Parameter, ParameterExpression, QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.analysis.gate_registry import GATES, _placed  # noqa: F401 - _placed: tests read it here
from qdensity.validation import Circuit, Instance, SequenceOf, validates

__all__ = [
    "moments",
    "moment_indices",
    "depth_of_gates",
    "instruction_generator",
    "parameter_of",
    "is_hamming_weight_preserving",
    "HW_PRESERVING_GATES",
    "GENERATOR_GATES",
]

#: Gates whose generator :func:`instruction_generator` knows (the families with a gradient),
#: read off the gate registry (:mod:`qdensity.analysis.gate_registry`).
GENERATOR_GATES = tuple(name for name, kind in GATES.items() if kind.generator is not None)

#: Names of gates that preserve Hamming weight (used by :func:`is_hamming_weight_preserving`),
#: read off the gate registry.
HW_PRESERVING_GATES = frozenset(
    name for name, kind in GATES.items() if kind.preserves_hamming_weight)

_SKIP = frozenset({"barrier", "measure", "delay"})


@validates(circuit=Circuit(), include_unparameterised=Instance(bool))
def moment_indices(
    circuit: QuantumCircuit, *, include_unparameterised: bool = True
) -> list[list[int]]:
    """Like :func:`moments`, but each layer lists positions in ``circuit.data``.

    Positions are stable identifiers (Qiskit builds new ``CircuitInstruction`` objects on each
    access, so object identity is not).

    Examples
    --------
    >>> from qiskit.circuit import Parameter, QuantumCircuit
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.ry(Parameter("a"), 0); _ = qc.ry(Parameter("b"), 1); _ = qc.cx(0, 1)
    >>> moment_indices(qc)
    [[0, 1], [2]]
    """
    front = [0] * circuit.num_qubits  # per qubit, the first layer free on it
    layers: list[list[int]] = []
    qindex = {q: i for i, q in enumerate(circuit.qubits)}  # = find_bit(q).index, at once
    for pos, inst in enumerate(circuit.data):
        qubits = [qindex[q] for q in inst.qubits]
        name = inst.operation.name
        if name == "barrier":
            level = max([front[q] for q in qubits], default=0)
            for q in qubits:
                front[q] = level
            continue
        if name in _SKIP:
            continue
        if not include_unparameterised and not _has_free_parameter(inst):
            continue
        level = max([front[q] for q in qubits], default=0)
        while len(layers) <= level:
            layers.append([])
        layers[level].append(pos)
        for q in qubits:
            front[q] = level + 1
    return layers


@validates(circuit=Circuit(), include_unparameterised=Instance(bool))
def moments(
    circuit: QuantumCircuit, *, include_unparameterised: bool = True
) -> list[list[CircuitInstruction]]:
    """Parallel layers (moments) of a circuit, as soon as possible.

    Each instruction is placed in the earliest layer after every earlier instruction that
    shares a qubit with it. Barriers synchronise the qubits they span but occupy no layer;
    measurements and delays are skipped.

    Parameters
    ----------
    circuit : QuantumCircuit
        Any circuit.
    include_unparameterised : bool, optional
        If False, only instructions with at least one free parameter are layered (the
        trainable structure, as used by the paper's layer-by-layer decompositions).

    Returns
    -------
    list of list of CircuitInstruction
        ``moments[m]`` holds the instructions of layer ``m`` in circuit order; within a layer
        no two instructions share a qubit.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> len(moments(round_robin(6)))
    5
    """
    layers = moment_indices(circuit, include_unparameterised=include_unparameterised)
    data = circuit.data
    return [[data[i] for i in layer] for layer in layers]


@validates(circuit=Circuit(), names=SequenceOf(Instance(str), min_len=0))
def depth_of_gates(circuit: QuantumCircuit, names: Sequence[str]) -> int:
    """Depth counting only gates whose name is in ``names`` (e.g. ``["rbs"]`` for RBS depth).

    Parameters
    ----------
    circuit : QuantumCircuit
    names : sequence of str
        Gate names that count.

    Returns
    -------
    int

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> depth_of_gates(round_robin(4), ["rbs"])
    3
    """
    wanted = set(names)
    return circuit.depth(filter_function=lambda inst: inst.operation.name in wanted)


def _has_free_parameter(inst: CircuitInstruction) -> bool:
    # a Parameter is its own free parameter (no set built for it)
    return any(isinstance(p, Parameter) or isinstance(p, ParameterExpression) and p.parameters
               for p in inst.operation.params)


@validates(inst=Instance(CircuitInstruction))
def parameter_of(inst: CircuitInstruction) -> tuple[Parameter, float] | None:
    """The single free parameter of a one-parameter gate and its linear coefficient.

    Parameters
    ----------
    inst : CircuitInstruction

    Returns
    -------
    (Parameter, float) or None
        ``(p, a)`` when the gate's angle is ``a * p`` (plus a constant); None for gates with
        no free parameter.

    Raises
    ------
    ValueError
        If the angle depends on more than one parameter or non-linearly on one.

    Examples
    --------
    >>> from qiskit.circuit import Parameter, QuantumCircuit
    >>> a = Parameter("a")
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.rz(2 * a, 0)
    >>> parameter_of(qc.data[0])
    (Parameter(a), 2.0)
    """
    exprs = [p for p in inst.operation.params if isinstance(p, ParameterExpression)]
    exprs = [e for e in exprs if e.parameters]
    if not exprs:
        return None
    if len(exprs) > 1:
        raise ValueError(f"gate {inst.operation.name!r} has several parameterised angles")
    expr = exprs[0]
    if len(expr.parameters) != 1:
        raise ValueError(
            f"gate {inst.operation.name!r} angle {expr} depends on several parameters; "
            "one parameter per gate is allowed"
        )
    (param,) = expr.parameters
    coeff = expr.gradient(param)
    if isinstance(coeff, ParameterExpression):
        if coeff.parameters:
            raise ValueError(f"gate angle {expr} is not linear in {param}")
        coeff = complex(coeff).real
    return param, float(coeff)


@validates(inst=Instance(CircuitInstruction), circuit=Circuit())
def instruction_generator(inst: CircuitInstruction, circuit: QuantumCircuit) -> SparsePauliOp:
    """Hermitian generator ``G`` with ``gate(angle) = exp(-i angle G)`` on the whole register.

    Supported (:data:`GENERATOR_GATES`): ``rx, ry, rz`` (``G = P/2``), ``rxx, ryy, rzz, rzx``
    (``G = P P / 2``), the controlled rotations ``crx, cry, crz`` (``G = |1><1| (x) P/2``,
    eigenvalues ``{-1/2, 0, 0, 1/2}``, so a four-term shift rule), the phases ``p``/``u1``
    (``G = -|1><1|``) and ``cp``/``cu1`` (``G = -|11><11|``), ``rbs`` (``G = Q = (X_i Y_j -
    Y_i X_j)/2`` in qubit-indexed notation, eigenvalues ``{-1, 0, 0, 1}``; paper eq. 8),
    ``fbs`` on ``[i, ..., j]`` (``G = Q Z_{i+1} ... Z_{j-1}``, Supp. E eq. 24) and
    ``PauliEvolutionGate`` (``G = H``): the generators of the gate registry
    (:mod:`qdensity.analysis.gate_registry`).

    Parameters
    ----------
    inst : CircuitInstruction
        One instruction of ``circuit``.
    circuit : QuantumCircuit
        The circuit, for qubit indices and width.

    Returns
    -------
    SparsePauliOp
        On ``circuit.num_qubits`` qubits, with respect to the gate's angle argument.

    Raises
    ------
    ValueError
        For a gate whose generator is not a known Pauli form.

    Examples
    --------
    ``RY(angle) = exp(-i angle Y / 2)``:

    >>> from qiskit.circuit import Parameter, QuantumCircuit
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.ry(Parameter("a"), 1)
    >>> instruction_generator(qc.data[0], qc)
    SparsePauliOp(['YI'],
                  coeffs=[0.5+0.j])
    """
    name = inst.operation.name
    kind = GATES.get(name)
    if kind is None or kind.generator is None:
        raise ValueError(
            f"no Pauli generator known for gate {name!r}; supported: {', '.join(GENERATOR_GATES)}"
        )
    q = [circuit.find_bit(b).index for b in inst.qubits]
    return kind.generator(inst.operation, q, circuit.num_qubits)


@validates(circuit=Circuit())
def is_hamming_weight_preserving(circuit: QuantumCircuit) -> bool:
    """Whether every gate of ``circuit`` preserves Hamming weight, read off the gate names.

    Unknown gates are judged by their matrix (diagonal-block check) when they have one.

    Parameters
    ----------
    circuit : QuantumCircuit

    Returns
    -------
    bool

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.circuits.ansatze import pyramid
    >>> is_hamming_weight_preserving(pyramid(4))
    True
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.x(0)
    >>> is_hamming_weight_preserving(qc)
    False
    """
    for inst in circuit.data:
        name = inst.operation.name
        if name in HW_PRESERVING_GATES:
            continue
        op = inst.operation
        if getattr(op, "definition", None) is not None and op.definition is not None:
            if is_hamming_weight_preserving(op.definition):
                continue
        try:
            mat = np.asarray(op.to_matrix())
        except Exception:
            return False
        weights = np.array([bin(i).count("1") for i in range(mat.shape[0])])
        mask = weights[:, None] != weights[None, :]
        if np.any(np.abs(mat[mask]) > 1e-12):
            return False
    return True
