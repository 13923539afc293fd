"""Commuting-generator gradient circuits (paper Methods eq. 9, Prop. 1, Cor. 2, Supp. F.2-F.3).

A *commuting block* is a run of trainable gates ``exp(-i angle G_j)`` whose generators mutually
commute (Bowles et al. 2023, "Backpropagation scaling in parameterised quantum circuits").
For a block that ends the circuit, ``f = <psi| H |psi>`` has

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

Circuits with several blocks (:func:`commuting_block_gradient`; paper Cor. 2, after Bowles et
al.'s commuting-block circuits): the last block is measured as above when its conditions hold.
For every earlier block ``b``, with ``rho`` the state after block ``b``, ``W`` the rest of the
circuit and ``O_t = W^dagger P_t W`` (an involution for a Pauli string ``P_t``),

    d f / d theta_j = sum_t h_t Tr[G~_j i[O_t, rho]]

(the roles of generator and observable exchanged). Two constructions measure the right-hand
side, both reading every derivative of the block from the same circuits, after a Clifford
``C_b`` that diagonalises the block's commuting generators (``C_b G~_j C_b^dagger |x> =
d_j(x) |x>``):

* ``method="shift"`` (default; no ancilla): ``i[O, rho] = e^{i pi/4 O} rho e^{-i pi/4 O} -
  e^{-i pi/4 O} rho e^{i pi/4 O}`` for an involution ``O`` (the two-term shift rule applied to
  the *observable*), and ``e^{+-i pi/4 O_t} = W^dagger e^{+-i pi/4 P_t} W``. Two ``n``-qubit
  circuits per block and term, ``prep; blocks <= b; W; exp(+-i pi/4 P_t); W^dagger; C_b``:
  ``2 (B - 1) + 1 = 2B - 1`` circuits for a Pauli observable, the count of Cor. 2.
* ``method="hadamard"``: ``Tr[G~_j i[O, rho]] = -2 Im <G~_j O>`` and
  ``Im <phi| G~_j O_t |phi> = E[y d_j(x)]`` on the ``n + 1``-qubit Hadamard test
  ``prep; blocks <= b; H(anc); W; controlled-P_t(anc); W^dagger; C_b; Y-measurement of anc``
  with ``y = +-1`` the ancilla's outcome. One circuit per block and term (``B`` for a Pauli
  observable), at the price of an ancilla and controlled Paulis.

Fixed Clifford gates at the end of ``W`` are not run forwards and backwards: they are absorbed
into the Pauli string (``P_t -> C^dagger P_t C``, a signed Pauli). Only the generators *within*
a block must commute; nothing is assumed between blocks, and for ``H = sum_t h_t P_t`` each
non-constant term needs its own circuits (``num_gradient_circuits`` reports the count emitted).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import (
    CircuitInstruction,
    Parameter,
    ParameterExpression,
    QuantumCircuit,
)
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Clifford, Pauli, PauliList, SparsePauliOp

from qdensity.analysis.pauli import (
    conjugate_two_qubit,
    diagonalising_clifford,
    first_noncommuting_pair,
    z_string_values,
)
from qdensity.analysis.structure import instruction_generator, parameter_of
from qdensity.circuits.gates import rbs_matrix
from qdensity.execution.plans import check_observable, measured
from qdensity.gradients.diagonalising import rbs_diagonalising_layer
from qdensity.models.decompositions import trainable_parameters
from qdensity.validation import check_circuit, check_rows_sum_to_one

__all__ = [
    "BLOCK_METHODS",
    "CommutingGradient",
    "CommutingBlockGradient",
    "commuting_gradient",
    "commuting_block_gradient",
    "commuting_blocks",
    "trainable_parameters",
]

_ATOL = 1e-12
_SKIP = frozenset({"barrier"})
_NON_UNITARY = frozenset({"measure", "reset", "delay"})


# --------------------------------------------------------------------------------------------
# structure
# --------------------------------------------------------------------------------------------


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


def _check_inputs(circuit, observable, parameters, diagonaliser):
    """Shared checks of the commuting-gradient builders: (params, observable)."""
    check_circuit(circuit)
    if circuit.num_clbits:
        raise ValueError(
            f"circuit must have no classical bits (it is measured here), got {circuit.num_clbits}"
        )
    if diagonaliser not in ("auto", "rbs", "clifford"):
        raise ValueError(
            f"diagonaliser must be 'auto', 'rbs' or 'clifford', got {diagonaliser!r}"
        )
    params = _check_parameters(circuit, parameters)
    if not isinstance(observable, SparsePauliOp):
        raise TypeError(f"observable must be a SparsePauliOp, got {type(observable).__name__}")
    op = check_observable(observable, circuit.num_qubits).simplify(atol=_ATOL)
    return params, SparsePauliOp(op.paulis, op.coeffs.real.astype(complex))


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


def _trainable_of(
    inst: CircuitInstruction, circuit: QuantumCircuit, index: int, params: set[Parameter]
) -> _Trainable:
    label = _label(inst, circuit, index)
    found = parameter_of(inst)
    if found is None or found[0] not in params:
        raise ValueError(f"gate {label} mixes trainable and other parameters; not supported")
    param, coeff = found
    try:
        gen = instruction_generator(inst, circuit)
    except ValueError as exc:
        raise ValueError(f"trainable gate {label}: {exc}") from exc
    return _Trainable(index, inst.operation.name, label, param, coeff, gen.simplify(atol=_ATOL))


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
    for idx in range(start, stop):
        inst = circuit.data[idx]
        name = inst.operation.name
        if name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            live.append(_trainable_of(inst, circuit, idx, params))
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
        qs = _qubits(inst, circuit)
        for t in live:
            t.generator = _evolve(t.generator, cliff, qs)
    for a in range(len(live)):
        for b in range(a + 1, len(live)):
            if not _commute(live[a].generator, live[b].generator):
                raise ValueError(
                    "generators do not commute, so these gates are not one commuting block: "
                    f"{live[a].label} (parameter {live[a].parameter}) and {live[b].label} "
                    f"(parameter {live[b].parameter})"
                )
    return live


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
    live: list[SparsePauliOp] = []
    for idx, inst in enumerate(circuit.data):
        if inst.operation.name in _SKIP:
            continue
        _check_unitary(inst, circuit, idx)
        if _is_trainable(inst, params):
            gen = _trainable_of(inst, circuit, idx, params).generator
            if start is not None and all(_commute(gen, g) for g in live):
                live.append(gen)
                continue
            if start is not None:
                blocks.append((start, idx))
            start, live = idx, [gen]
            continue
        if start is None:
            continue
        cliff = _clifford_of(inst)
        if cliff is None:
            blocks.append((start, idx))
            start, live = None, []
        else:
            qs = _qubits(inst, circuit)
            live = [_evolve(g, cliff, qs) for g in live]
    if start is not None:
        blocks.append((start, len(circuit.data)))
    if not blocks:
        raise ValueError("circuit has no trainable gates for the given parameters")
    return blocks


# --------------------------------------------------------------------------------------------
# post-processing helpers
# --------------------------------------------------------------------------------------------


def _diagonal_matrix(diag_ops: Sequence[SparsePauliOp], num_qubits: int) -> np.ndarray:
    """Values of diagonal operators on every basis state: shape ``(2**n, len(diag_ops))``."""
    labels: dict[str, int] = {}
    entries: list[tuple[int, int, float]] = []
    for col, op in enumerate(diag_ops):
        for label, coeff in op.to_list():
            if abs(coeff) <= _ATOL:
                continue
            if abs(coeff.imag) > 1e-9:
                raise RuntimeError(f"diagonal observable has a complex coefficient: {op}")
            row = labels.setdefault(label, len(labels))
            entries.append((row, col, coeff.real))
    out = np.zeros((2**num_qubits, len(diag_ops)))
    if not labels:
        return out
    vals = z_string_values(PauliList(list(labels)), num_qubits)
    coeffs = np.zeros((len(labels), len(diag_ops)))
    for row, col, c in entries:
        coeffs[row, col] += c
    return vals @ coeffs


def _check_probs(probs, dim: int, name: str = "probs") -> np.ndarray:
    try:
        arr = np.asarray(probs, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of probabilities, got {probs!r}") from exc
    if arr.ndim not in (1, 2) or arr.shape[-1] != dim:
        raise ValueError(
            f"{name} must have shape ({dim},) or (rows, {dim}) (one probability per measured "
            f"bitstring, index = integer with clbit j as bit j), got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    check_rows_sum_to_one(arr, name)
    return arr


def _check_shots(shots, rows: int) -> np.ndarray:
    arr = np.asarray(shots)
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"shots must be an int or an integer array, got {shots!r}")
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != rows):
        raise ValueError(f"shots must be an int or have shape ({rows},), got shape {arr.shape}")
    if np.any(arr < 2):
        raise ValueError(f"shots must be >= 2 to estimate a variance, got {shots!r}")
    return np.broadcast_to(arr.astype(float), (rows,))


def _measured(circuit: QuantumCircuit, tail: QuantumCircuit | None) -> QuantumCircuit:
    out = circuit.copy()
    if tail is not None and tail.size():
        out.barrier()
        out.compose(tail, qubits=range(tail.num_qubits), inplace=True)
    return measured(out)


# --------------------------------------------------------------------------------------------
# measured circuits + post-processing (shared by one- and multi-block gradients)
# --------------------------------------------------------------------------------------------


@dataclass
class _GradientCircuits:
    """Measured circuits and, per circuit, the estimator's value on every outcome."""

    circuits: list[QuantumCircuit]
    parameters: list[Parameter]
    _values: list[np.ndarray] = field(repr=False)

    @property
    def num_gradient_circuits(self) -> int:
        """Distinct circuits per data point (``len(circuits)``)."""
        return len(self.circuits)

    def value_matrices(self) -> list[np.ndarray]:
        """Per circuit, shape ``(2**width, P)``: each parameter's estimator on each outcome."""
        return [v.copy() for v in self._values]

    def _as_list(self, probs) -> list[np.ndarray]:
        if len(self.circuits) == 1 and not isinstance(probs, (list, tuple)):
            probs = [probs]
        if not isinstance(probs, (list, tuple)) or len(probs) != len(self.circuits):
            raise ValueError(
                f"probs must be a list of {len(self.circuits)} arrays, one per circuit in "
                "`circuits` order (a single array is accepted when there is one circuit)"
            )
        arrs = [
            _check_probs(p, v.shape[0], f"probs[{c}]")
            for c, (p, v) in enumerate(zip(probs, self._values, strict=True))
        ]
        if len({a.shape[:-1] for a in arrs}) != 1:
            raise ValueError("the probability arrays must all have the same number of rows")
        return arrs

    def gradient_from_probabilities(self, probs) -> np.ndarray:
        """Gradient from the outcome probabilities of the circuits.

        Parameters
        ----------
        probs : array_like or sequence of array_like
            Per circuit, shape ``(rows, 2**width)`` or ``(2**width,)``: exact or empirical
            probability of each measured bitstring, index = integer of the bitstring with
            clbit ``j`` as bit ``j``. A single array when there is one circuit.

        Returns
        -------
        numpy.ndarray, shape (rows, P) or (P,)
            ``d f / d p`` for each parameter of :attr:`parameters`.
        """
        arrs = self._as_list(probs)
        return sum(a @ v for a, v in zip(arrs, self._values, strict=True))

    def standard_error(self, probs, shots) -> np.ndarray:
        """Standard error of each gradient estimate.

        Each shot of a circuit gives one value of every parameter's estimator; per circuit the
        error is ``s^2 / shots`` with ``s^2`` the unbiased sample variance of those values
        (``shots / (shots - 1)`` times the variance under ``probs``); independent circuits add.

        Parameters
        ----------
        probs : array_like or sequence of array_like
            Empirical frequencies, as in :meth:`gradient_from_probabilities`.
        shots : int or sequence of int
            Shots per circuit (one int for all circuits, or one per circuit), each ``>= 2``.

        Returns
        -------
        numpy.ndarray, shape (rows, P) or (P,)
        """
        arrs = self._as_list(probs)
        per_circuit = [shots] * len(arrs) if np.ndim(shots) == 0 else list(shots)
        if len(per_circuit) != len(arrs):
            raise ValueError(
                f"shots must be an int or one int per circuit ({len(arrs)}), got {shots!r}"
            )
        total = 0.0
        for a, v, s in zip(arrs, self._values, per_circuit, strict=True):
            two_d = np.atleast_2d(a)
            n_shots = _check_shots(s, two_d.shape[0])
            mean = two_d @ v
            var = np.maximum(two_d @ v**2 - mean**2, 0.0)  # rounding can give -1e-17
            total = total + var / (n_shots[:, None] - 1.0)
        se = np.sqrt(total)
        return se if arrs[0].ndim == 2 else se[0]


# --------------------------------------------------------------------------------------------
# one commuting block
# --------------------------------------------------------------------------------------------


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
        return self._values[0].copy()


def _gradient_terms(
    trainables: Sequence[_Trainable], observable: SparsePauliOp, params: Sequence[Parameter]
) -> tuple[dict[Parameter, SparsePauliOp], list[tuple[str, dict[Parameter, SparsePauliOp],
                                                       list[tuple[str, _Trainable]]]]]:
    """Total ``O_p`` and, per non-constant Pauli term ``P_t`` of ``H``, its share ``O_{p,t}``
    with the (term, gate) origin of each Pauli string."""
    n = observable.num_qubits
    zero = SparsePauliOp(["I" * n], [0.0])
    total = {p: zero for p in params}
    per_term = []
    for label, h in observable.to_list():
        if set(label) == {"I"} or abs(h) <= _ATOL:
            continue
        term = SparsePauliOp([label], [h.real])
        shares = {p: zero for p in params}
        origin: list[tuple[str, _Trainable]] = []
        for t in trainables:
            o = (1j * _commutator(t.generator, term)).simplify(atol=_ATOL)
            if _is_zero(o):
                continue
            shares[t.parameter] = (shares[t.parameter] + t.coeff * o).simplify(atol=_ATOL)
            origin.extend((lab, t) for lab, c in o.to_list() if abs(c) > _ATOL)
        per_term.append((label, shares, origin))
        for p in params:
            total[p] = (total[p] + shares[p]).simplify(atol=_ATOL)
    return total, per_term


def _rbs_layer_for(
    trainables: Sequence[_Trainable], observables: dict[Parameter, SparsePauliOp], n: int
) -> tuple[QuantumCircuit, dict[Parameter, SparsePauliOp]] | None:
    """The RBS(pi/4) layer of Supp. F.3 when every trainable gate is an RBS, the pairs are
    disjoint and the layer diagonalises every gradient observable; else None."""
    if not trainables or any(t.name != "rbs" for t in trainables):
        return None
    pairs: list[tuple[int, int]] = []
    for t in trainables:
        support = np.flatnonzero(np.any(t.generator.paulis.x | t.generator.paulis.z, axis=0))
        if len(support) != 2:
            return None
        pair = (int(support[0]), int(support[1]))
        if pair not in pairs:
            pairs.append(pair)
    used = [q for p in pairs for q in p]
    if len(used) != len(set(used)):
        return None
    layer = rbs_diagonalising_layer(n, pairs)
    umat = rbs_matrix(np.pi / 4)
    diag = {}
    for p, op in observables.items():
        for pair in pairs:
            op = conjugate_two_qubit(op, umat, pair)
        if op.paulis.x.any() and not _is_zero(op):
            return None
        diag[p] = op
    return layer, diag


def _group_terms(per_term, params):
    """Greedy grouping of ``H``'s terms so that all gradient strings of a group commute."""
    groups: list[dict] = []
    for label, shares, origin in per_term:
        strings = [lab for lab, _ in origin]
        if strings:
            bad = first_noncommuting_pair(strings)
            if bad is not None:
                (la, ta), (lb, tb) = origin[bad[0]], origin[bad[1]]
                raise ValueError(
                    f"gradient terms for observable term {label} do not commute: {la} from "
                    f"i[G, {label}] of {ta.label} (parameter {ta.parameter}) anticommutes with "
                    f"{lb} from {tb.label} (parameter {tb.parameter}); each Pauli term of the "
                    "observable must commute or anticommute with every (propagated) generator "
                    "(Bowles et al., Thm. 1)"
                )
        for g in groups:
            if not strings or first_noncommuting_pair(g["strings"] + strings) is None:
                g["labels"].append(label)
                g["strings"].extend(strings)
                for p in params:
                    g["ops"][p] = (g["ops"][p] + shares[p]).simplify(atol=_ATOL)
                break
        else:
            groups.append({"labels": [label], "strings": list(strings), "ops": dict(shares)})
    return groups


def _direct_gradient(
    circuit: QuantumCircuit,
    trainables: Sequence[_Trainable],
    observable: SparsePauliOp,
    params: Sequence[Parameter],
    diagonaliser: str,
) -> CommutingGradient:
    n = circuit.num_qubits
    total, per_term = _gradient_terms(trainables, observable, params)
    all_labels = [label for label, _, _ in per_term]
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
            raise ValueError(
                "diagonaliser='rbs' needs RBS trainable gates on disjoint pairs whose gradient "
                "observables the RBS(pi/4) layer diagonalises (Supp. F.3); use 'clifford' or "
                "'auto'"
            )
    groups = _group_terms(per_term, params)
    if not groups:  # H is a multiple of the identity: every derivative vanishes
        groups = [{"labels": [], "strings": [], "ops": dict(total)}]
    circuits, values, diag_circs, diags = [], [], [], []
    for g in groups:
        strings = sorted(set(g["strings"]))
        diag_circ = (
            diagonalising_clifford(strings)[0] if strings else QuantumCircuit(n, name="diagonalise")
        )
        cliff = Clifford(diag_circ)
        diag = {
            p: _evolve(op, cliff, list(range(n))).simplify(atol=_ATOL) for p, op in g["ops"].items()
        }
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
        elimination (:func:`qdensity.pauli.diagonalising_clifford`); ``"auto"`` prefers
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
    >>> from qdensity.ansatze import pairs_circuit
    >>> qc = pairs_circuit(4, [[(0, 1), (2, 3)]])
    >>> grad = commuting_gradient(qc, SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4))
    >>> grad.num_gradient_circuits, grad.diagonaliser
    (1, 'rbs')
    """
    params, obs = _check_inputs(circuit, observable, parameters, diagonaliser)
    pset = set(params)
    first = next(
        (i for i, inst in enumerate(circuit.data) if _is_trainable(inst, pset)), None
    )
    if first is None:
        raise ValueError(f"no gate of the circuit depends on the parameters {params}")
    trainables = _analyse_block(circuit, first, len(circuit.data), pset)
    return _direct_gradient(circuit, trainables, obs, params, diagonaliser)


# --------------------------------------------------------------------------------------------
# several commuting blocks
# --------------------------------------------------------------------------------------------


BLOCK_METHODS = ("shift", "hadamard")


@dataclass
class CommutingBlockGradient(_GradientCircuits):
    """Gradient circuits of a multi-block commuting circuit and their post-processing.

    Attributes
    ----------
    circuits : list of QuantumCircuit
        Measured circuits (register ``"meas"``, clbit ``j`` = qubit ``j``). Hadamard-test
        circuits have ``n + 1`` qubits, the ancilla last.
    parameters : list of Parameter
    roles : list of str
        What each circuit measures, e.g. ``"block 0, term ZI (observable shift +)"``.
    blocks : list of (int, int)
        Block ranges into the input circuit's ``data``.
    method : str
        ``"shift"`` or ``"hadamard"`` (module docstring).
    """

    roles: list[str] = field(default_factory=list)
    blocks: list[tuple[int, int]] = field(default_factory=list)
    method: str = "shift"


def _subcircuit(circuit: QuantumCircuit, start: int, stop: int) -> QuantumCircuit:
    out = QuantumCircuit(circuit.num_qubits)
    for inst in circuit.data[start:stop]:
        if inst.operation.name not in _SKIP:
            out.append(inst.operation, _qubits(inst, circuit))
    return out


def _rest_of_circuit(circuit: QuantumCircuit, stop: int) -> tuple[QuantumCircuit, Clifford | None]:
    """``(W', C)`` with ``W = C W'`` for ``W = data[stop:]``: ``C`` collects the fixed Clifford
    gates at the end of ``W`` (None when there are none), to be absorbed into each Pauli."""
    size = len(circuit.data)
    cut = size
    while cut > stop and (
        circuit.data[cut - 1].operation.name in _SKIP or _clifford_of(circuit.data[cut - 1])
        is not None
    ):
        cut -= 1
    suffix = Clifford(_subcircuit(circuit, cut, size)) if cut < size else None
    return _subcircuit(circuit, stop, cut), suffix


def _absorbed(label: str, suffix: Clifford | None) -> tuple[Pauli, float]:
    """``(P', s)`` with ``C^dagger P C = s P'`` (``s = +-1``), ``C`` the absorbed Cliffords."""
    pauli = Pauli(label)
    if suffix is not None:
        pauli = pauli.evolve(suffix, frame="h")
    sign = complex((-1j) ** pauli.phase)
    if abs(sign.imag) > 1e-12:  # conjugation keeps a Hermitian Pauli Hermitian
        raise RuntimeError(f"Clifford conjugation of {label} gave a non-Hermitian {pauli}")
    pauli.phase = 0
    return pauli, sign.real


def _support(pauli: Pauli) -> list[int]:
    return [int(q) for q in np.flatnonzero(pauli.x | pauli.z)]


def _block_circuit(
    head: QuantumCircuit,
    rest: QuantumCircuit,
    pauli: Pauli,
    diag_circ: QuantumCircuit,
    method: str,
    direction: int = 0,
) -> QuantumCircuit:
    """``head (prep + blocks<=b); W'; middle; W'^dag; C_b`` (measured). ``middle`` is
    ``exp(direction i pi/4 P)`` (shift) or ``H(anc)...controlled-P...Y-measure`` (Hadamard)."""
    n = head.num_qubits
    width = n + 1 if method == "hadamard" else n
    out = QuantumCircuit(width, name=f"{head.name}_{method}")
    out.compose(head, qubits=range(n), inplace=True)
    if method == "hadamard":
        out.h(n)
    out.compose(rest, qubits=range(n), inplace=True)
    support = _support(pauli)
    if method == "hadamard":
        for q in support:
            getattr(out, {(True, False): "cx", (True, True): "cy", (False, True): "cz"}[
                (bool(pauli.x[q]), bool(pauli.z[q]))])(n, q)
    else:  # PauliEvolutionGate(P, t) = exp(-i t P)
        reduced = pauli[support]
        out.append(PauliEvolutionGate(reduced, time=-direction * np.pi / 4), support)
    out.compose(rest.inverse(), qubits=range(n), inplace=True)
    out.compose(diag_circ, qubits=range(n), inplace=True)
    if method == "hadamard":
        out.sdg(n)
        out.h(n)
    return _measured(out, None)


def _block_values(
    trainables: Sequence[_Trainable],
    diag_gens: Sequence[SparsePauliOp],
    params: Sequence[Parameter],
    n: int,
) -> np.ndarray:
    """Shape ``(2**n, P)``: ``sum over p's gates of a d_j(x)`` on each system outcome."""
    col = {p: k for k, p in enumerate(params)}
    d = _diagonal_matrix(list(diag_gens), n)  # (2**n, gates)
    out = np.zeros((2**n, len(params)))
    for j, t in enumerate(trainables):
        out[:, col[t.parameter]] += t.coeff * d[:, j]
    return out


def _check_blocks(blocks, circuit: QuantumCircuit, pset: set[Parameter]) -> list[tuple[int, int]]:
    size = len(circuit.data)
    out: list[tuple[int, int]] = []
    prev = 0
    try:
        items = [(int(a), int(b)) for a, b in blocks]
    except (TypeError, ValueError) as exc:
        raise TypeError(f"blocks must be a sequence of (start, stop) ints, got {blocks!r}") from exc
    if not items:
        raise ValueError("blocks must contain at least one (start, stop) range")
    for a, b in items:
        if not (prev <= a < b <= size):
            raise ValueError(
                f"blocks must be increasing, non-overlapping ranges within [0, {size}], got "
                f"{(a, b)} after stop {prev}"
            )
        out.append((a, b))
        prev = b
    for idx, inst in enumerate(circuit.data):
        if _is_trainable(inst, pset) and not any(a <= idx < b for a, b in out):
            raise ValueError(
                f"trainable gate {_label(inst, circuit, idx)} lies in no block of {out}"
            )
    return out


def _try_direct(circuit, start, stop, obs, params, pset, diagonaliser):
    """The last block's one-circuit-per-group measurement, or None when it does not apply."""
    if not all(
        inst.operation.name in _SKIP or _clifford_of(inst) is not None
        for inst in circuit.data[stop:]
    ):
        return None
    try:
        trainables = _analyse_block(circuit, start, len(circuit.data), pset)
        return _direct_gradient(circuit, trainables, obs, params, diagonaliser)
    except ValueError:
        return None


def commuting_block_gradient(
    circuit: QuantumCircuit,
    observable: SparsePauliOp,
    blocks: Sequence[tuple[int, int]] | None = None,
    parameters: Sequence[Parameter] | None = None,
    *,
    method: str = "shift",
    diagonaliser: str = "auto",
) -> CommutingBlockGradient:
    """Gradient circuits of a commuting-block circuit (paper eq. 9, Cor. 2).

    The last block is measured with one circuit (:func:`commuting_gradient`'s construction)
    when it ends the circuit up to fixed Clifford gates and its gradient observables are
    simultaneously diagonalisable. Every earlier block (and the last one when that fails) is
    measured through the rest of the circuit ``W``, per non-constant Pauli term ``P_t`` of
    ``H`` (module docstring): with ``method="shift"`` by two ``n``-qubit circuits that rotate
    by ``exp(+-i pi/4 P_t)`` between ``W`` and ``W^dagger``, with ``method="hadamard"`` by one
    ``n + 1``-qubit Hadamard test. All derivatives of a block come from the same circuits, read
    in the eigenbasis of its commuting generators. Only the generators *within* a block must
    commute; nothing is assumed between blocks.

    Parameters
    ----------
    circuit : QuantumCircuit
        ``n`` qubits, unitary, no classical bits.
    observable : SparsePauliOp
        Hermitian ``H`` on ``n`` qubits with ``T`` non-constant Pauli terms.
    blocks : sequence of (int, int), optional
        ``(start, stop)`` ranges into ``circuit.data``; default :func:`commuting_blocks`.
    parameters : sequence of Parameter, optional
        Default all parameters outside the vector ``"x"``.
    method : {"shift", "hadamard"}
        ``"shift"`` (default): no ancilla, ``2 T (B - 1) + L`` circuits, i.e. ``2B - 1`` for a
        Pauli observable (Cor. 2). ``"hadamard"``: ``T (B - 1) + L`` circuits on ``n + 1``
        qubits with controlled Paulis. ``L`` is the last block's count: its term groups (1 when
        all its gradient strings commute) when measured directly, else as an earlier block.
    diagonaliser : {"auto", "rbs", "clifford"}
        For the last block's direct circuit, as in :func:`commuting_gradient`.

    Returns
    -------
    CommutingBlockGradient
        ``.circuits``, ``.roles``, ``.num_gradient_circuits``,
        ``.gradient_from_probabilities(list of probs)`` -> ``(rows, P)``,
        ``.standard_error(list of probs, shots)``.

    Raises
    ------
    ValueError
        Blocks whose generators do not commute (names both gates), a non-Clifford fixed gate
        inside a block, wrong observable width, blocks not covering the trainable gates, an
        unknown method.

    Examples
    --------
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.ansatze import pyramid
    >>> z0 = SparsePauliOp.from_sparse_list([("Z", [0], 1)], 3)
    >>> g = commuting_block_gradient(pyramid(3), z0)
    >>> len(g.blocks), g.num_gradient_circuits
    (3, 5)
    >>> commuting_block_gradient(pyramid(3), z0, method="hadamard").num_gradient_circuits
    3
    """
    if method not in BLOCK_METHODS:
        raise ValueError(f"method must be one of {BLOCK_METHODS}, got {method!r}")
    params, obs = _check_inputs(circuit, observable, parameters, diagonaliser)
    pset = set(params)
    n = circuit.num_qubits
    if blocks is None:
        blocks = commuting_blocks(circuit, params)
    else:
        blocks = _check_blocks(blocks, circuit, pset)
    circuits: list[QuantumCircuit] = []
    roles: list[str] = []
    values: list[np.ndarray] = []
    terms = [
        (label, coeff.real)
        for label, coeff in obs.to_list()
        if abs(coeff) > _ATOL and set(label) != {"I"}  # constant terms have zero derivative
    ]
    for b, (start, stop) in enumerate(blocks):
        trainables = _analyse_block(circuit, start, stop, pset)
        if not trainables:
            raise ValueError(f"block {b} = {(start, stop)} holds no trainable gate")
        direct = None
        if b == len(blocks) - 1:
            direct = _try_direct(circuit, start, stop, obs, params, pset, diagonaliser)
        if direct is not None:
            for c, (circ, val) in enumerate(
                zip(direct.circuits, direct.value_matrices(), strict=True)
            ):
                circuits.append(circ)
                terms_c = ", ".join(direct.term_groups[c]) or "none"
                roles.append(
                    f"block {b} (direct, {direct.diagonaliser} diagonaliser, terms {terms_c})"
                )
                values.append(val)
            continue
        gen_terms = [lab for t in trainables for lab, c in t.generator.to_list() if abs(c) > _ATOL]
        pair = first_noncommuting_pair(gen_terms)
        if pair is not None:
            raise ValueError(
                f"block {b}: generator terms {gen_terms[pair[0]]} and {gen_terms[pair[1]]} "
                "anticommute, so no Clifford diagonalises the block's generators"
            )
        diag_circ, _ = diagonalising_clifford(gen_terms)
        cliff = Clifford(diag_circ)
        diag_gens = [_evolve(t.generator, cliff, list(range(n))) for t in trainables]
        sys_vals = _block_values(trainables, diag_gens, params, n)
        head = _subcircuit(circuit, 0, stop)
        head.name = circuit.name
        rest, suffix = _rest_of_circuit(circuit, stop)
        for label, h in terms:
            pauli, sign = _absorbed(label, suffix)
            if method == "hadamard":
                circuits.append(_block_circuit(head, rest, pauli, diag_circ, method))
                roles.append(f"block {b}, term {label} (Hadamard test)")
                y = np.array([1.0, -1.0])  # ancilla bit 0 -> Y = +1
                vals = -2.0 * h * sign * (y[:, None, None] * sys_vals[None, :, :])
                values.append(vals.reshape(2 ** (n + 1), len(params)))
                continue
            for direction in (1, -1):
                circuits.append(
                    _block_circuit(head, rest, pauli, diag_circ, method, direction)
                )
                roles.append(
                    f"block {b}, term {label} (observable shift {'+' if direction > 0 else '-'})"
                )
                values.append(direction * h * sign * sys_vals)
    return CommutingBlockGradient(
        circuits=circuits,
        parameters=list(params),
        _values=values,
        roles=roles,
        blocks=list(blocks),
        method=method,
    )
