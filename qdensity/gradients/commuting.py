"""Commuting-generator gradient circuits (paper Methods eq. 9, Prop. 1, Cor. 2, Supp. F.2-F.3).

A *commuting block* is a run of trainable gates ``exp(-i angle G_j)`` whose generators mutually
commute (Bowles et al. 2023, "Backpropagation scaling in parameterised quantum circuits").
For a block that ends the circuit, ``f = <psi| H |psi>`` has::

    d f / d theta_j = i <psi| [G_j, H] |psi>                                  (Methods, eq. 9)

and when every generator commutes or anticommutes with a Pauli string ``P`` the gradient
observables ``i [G_j, P]`` commute (Bowles et al., Thm. 1): one circuit, the input circuit
followed by a diagonalising unitary and a computational-basis measurement, gives every partial
derivative at once (:func:`commuting_gradient`). For ``H = sum_t h_t P_t`` the terms of ``H``
are grouped so that all gradient strings of a group commute, one circuit per group (one in
total for, e.g., ``sum_i c_i Z_i`` after an RBS moment; ``n`` for ``sum_i Z_i`` after an ``RY``
layer and a CNOT ladder, whose gradient observables do not commute).

Fixed Clifford gates interleaved with or following the trainable gates (the CNOT ladder of a
hardware-efficient layer) are absorbed by propagating each generator to the end of its block,
``G~ = C G C^dagger`` with ``C`` the Clifford gates after the gate.

The block analysis (trainable gates, propagated generators, :func:`commuting_blocks`) lives in
:mod:`qdensity.analysis.blocks`, the diagonalising circuits in
:mod:`qdensity.gradients.diagonalising`, the one-block measurement behind
:func:`commuting_gradient` (:class:`CommutingGradient`) in ``qdensity.gradients._direct``.
Circuits with several blocks (:func:`commuting_block_gradient`; paper Cor. 2) are handled in
:mod:`qdensity.gradients.blocks`; their names are re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.analysis.blocks import _analyse_block, _is_trainable, commuting_blocks
from qdensity.analysis.parameters import trainable_parameters
from qdensity.gradients._circuits import _check_inputs
from qdensity.gradients._direct import CommutingGradient, _circuit_count, _direct_gradient
from qdensity.gradients.blocks import (
    BLOCK_METHODS,
    CommutingBlockGradient,
    commuting_block_gradient,
)
from qdensity.validation import Circuit, Instance, Observable, Options, SequenceOf, validates

__all__ = [
    "BLOCK_METHODS",
    "CommutingGradient",
    "CommutingBlockGradient",
    "commuting_gradient",
    "commuting_gradient_count",
    "commuting_block_gradient",
    "commuting_blocks",
    "trainable_parameters",
]


@validates(
    circuit=Circuit(min_qubits=1), observable=Observable(),
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    diagonaliser=Options(('auto', 'rbs', 'clifford')),
)
def commuting_gradient(
    circuit: QuantumCircuit,
    observable: SparsePauliOp,
    parameters: Sequence[Parameter] | None = None,
    *,
    diagonaliser: str = "auto",
) -> CommutingGradient:
    """Gradient circuit of a commuting-generator circuit (paper Methods eq. 9; Bowles Thm. 1).

    The circuit is (gates without trainable parameters: state preparation) followed by one
    commuting block of trainable gates ``exp(-i (a p + b) G)``, possibly interleaved with or
    followed by fixed Clifford gates. Each generator is propagated to the end of the circuit
    (``G~ = C G C^dagger``, ``C`` the Clifford gates after it); then
    ``d f / d p = <psi| O_p |psi>`` with ``O_p = sum over p's gates of a i [G~, H]``, and all
    ``O_p`` are measured from one circuit after a diagonalising unitary.

    Bowles et al.'s Thm. 1 needs each generator to commute or anticommute with ``H``. For a
    single Pauli string (or any ``H`` whose gradient terms all commute, such as ``sum c_i Z_i``
    after one RBS moment) this is one circuit. When ``H`` is a sum whose terms give
    anticommuting gradient strings (``sum_i Z_i`` after single-qubit ``RY`` rotations and a
    CNOT ladder, or after ``X``-string evolutions), the terms of ``H`` are grouped greedily so
    that each group's strings commute, and each group is one circuit; the count is reported by
    ``num_gradient_circuits``, never assumed.

    Parameters
    ----------
    circuit : QuantumCircuit
        ``n`` qubits, unitary, no classical bits.
    observable : SparsePauliOp
        Hermitian ``H`` on ``n`` qubits.
    parameters : sequence of Parameter, optional
        Parameters to differentiate; default all parameters not in a vector named ``"x"``.
        A parameter may be shared by several gates (contributions add).
    diagonaliser : {"auto", "rbs", "clifford"}
        ``"rbs"``: the ``RBS(pi/4)`` layer of Supp. F.3 (RBS gates on disjoint pairs, e.g. one
        round-robin moment with ``H`` a sum of ``Z_i``); ``"clifford"``: symplectic
        elimination (:func:`qdensity.analysis.pauli.diagonalising_clifford`); ``"auto"`` prefers
        ``"rbs"`` when it applies.

    Returns
    -------
    CommutingGradient
        ``.circuits`` (measured; ``.circuit`` when there is one), ``.parameters``,
        ``.observables``, ``.gradient_from_probabilities(probs)`` -> ``(rows, P)``,
        ``.standard_error(probs, shots)``, ``.num_gradient_circuits``.

    Raises
    ------
    ValueError
        If two trainable generators do not commute (names both gates), a fixed gate after the
        first trainable one is not Clifford, the observable has the wrong width or is not
        Hermitian, or the gradient strings of one term of ``H`` do not commute (names the
        term, the strings and the gates).

    Examples
    --------
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import pairs_circuit
    >>> qc = pairs_circuit(4, [[(0, 1), (2, 3)]])
    >>> grad = commuting_gradient(qc, SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4))
    >>> grad.num_gradient_circuits, grad.diagonaliser
    (1, 'rbs')
    """
    params, obs, trainables = _one_block(circuit, observable, parameters, diagonaliser)
    return _direct_gradient(circuit, trainables, obs, params, diagonaliser)


def _first_trainable(circuit, pset) -> int | None:
    """Position of the first gate depending on ``pset`` (``_is_trainable``), else None; a
    gate whose angle is a ``Parameter`` is tested by one set lookup (the data loader's gates
    before the block, at every sub-unitary)."""
    for i, inst in enumerate(circuit.data):
        ps = inst.operation.params
        if len(ps) == 1 and isinstance(p := ps[0], Parameter):
            if p in pset:
                return i
        elif ps and _is_trainable(inst, pset):
            return i
    return None


def _one_block(circuit, observable, parameters, diagonaliser):
    """Checked ``(params, observable, trainable gates)`` of a one-block circuit."""
    params, obs = _check_inputs(circuit, observable, parameters, diagonaliser)
    pset = set(params)
    first = _first_trainable(circuit, pset)
    if first is None:
        raise ValueError(f"no gate of the circuit depends on the parameters {params}")
    return params, obs, _analyse_block(circuit, first, len(circuit.data), pset)


@validates(
    circuit=Circuit(min_qubits=1), observable=Observable(),
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    diagonaliser=Options(('auto', 'rbs', 'clifford')),
)
def commuting_gradient_count(
    circuit: QuantumCircuit,
    observable: SparsePauliOp,
    parameters: Sequence[Parameter] | None = None,
    *,
    diagonaliser: str = "auto",
) -> int:
    """``commuting_gradient(...).num_gradient_circuits`` without building the circuits.

    The same analysis (blocks, gradient strings, their grouping, the ``RBS(pi/4)`` layer test)
    and the same errors; no measured copies of ``circuit``, diagonalising circuits or estimator
    tables are made (for a count at device widths, e.g. Table 1).

    Parameters
    ----------
    circuit, observable, parameters, diagonaliser
        As for :func:`commuting_gradient`.

    Returns
    -------
    int
        Distinct circuits per data point.

    Examples
    --------
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import pairs_circuit
    >>> commuting_gradient_count(pairs_circuit(4, [[(0, 1), (2, 3)]]),
    ...                          SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4))
    1
    """
    params, obs, trainables = _one_block(circuit, observable, parameters, diagonaliser)
    return _circuit_count(trainables, obs, params, diagonaliser, circuit.num_qubits)
