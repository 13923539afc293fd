"""Gradient circuits of circuits with several commuting blocks (paper eq. 9, Cor. 2; Methods
"Commuting-block quantum neural networks", after Bowles et al.'s commuting-block circuits).

Blocks are read off the circuit by :func:`qdensity.analysis.blocks.commuting_blocks`. The last
block is measured directly (:mod:`qdensity.gradients.commuting`) when its conditions hold.
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
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Clifford, Pauli, SparsePauliOp

from qdensity.analysis.blocks import (
    _ATOL,
    _SKIP,
    _analyse_block,
    _clifford_of,
    _evolve,
    _is_trainable,
    _label,
    _qubits,
    _Trainable,
    commuting_blocks,
)
from qdensity.analysis.pauli import (
    ZStringTable,
    diagonalising_clifford,
    first_noncommuting_pair,
)
from qdensity.gradients._circuits import _check_inputs, _GradientCircuits
from qdensity.gradients._direct import _direct_gradient
from qdensity.gradients.diagonalising import _diagonal_matrix, _measured
from qdensity.validation import (
    Circuit,
    Instance,
    Interval,
    Observable,
    Options,
    SequenceOf,
    validates,
)

__all__ = ["BLOCK_METHODS", "CommutingBlockGradient", "commuting_block_gradient"]

BLOCK_METHODS = ("shift", "hadamard")


@validates(
    circuits=Instance(list), parameters=Instance(list), _values=Instance(list),
    roles=Instance(list), blocks=Instance(list), method=Options(BLOCK_METHODS),
)
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

    Examples
    --------
    The pyramid's three RBS blocks, against central finite differences of ``<Z_0>``:

    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.quantum_info import SparsePauliOp, Statevector
    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.gradients import commuting_block_gradient
    >>> qc = QuantumCircuit(3); _ = qc.x(0); qc = qc.compose(pyramid(3))
    >>> z0, v = SparsePauliOp("IIZ"), np.array([0.3, 0.5, 0.7])
    >>> grad = commuting_block_gradient(qc, z0)
    >>> probs = [Statevector(c.remove_final_measurements(inplace=False).assign_parameters(v))
    ...          .probabilities() for c in grad.circuits]
    >>> f = lambda w: Statevector(qc.assign_parameters(w)).expectation_value(z0).real
    >>> fd = [(f(v + 1e-6 * e) - f(v - 1e-6 * e)) / 2e-6 for e in np.eye(3)]
    >>> grad.blocks, bool(np.allclose(grad.gradient_from_probabilities(probs), fd, atol=1e-6))
    ([(1, 2), (2, 3), (3, 4)], True)
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
) -> ZStringTable:
    """``(2**n, P)`` as a table: ``sum over p's gates of a d_j(x)`` on each system outcome."""
    col = {p: k for k, p in enumerate(params)}
    d = _diagonal_matrix(list(diag_gens), n)  # columns: gates
    mix = np.zeros((len(trainables), len(params)))
    for j, t in enumerate(trainables):
        mix[j, col[t.parameter]] += t.coeff
    return ZStringTable(d.z, d.coefficients @ mix)


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


@validates(
    circuit=Circuit(min_qubits=1), observable=Observable(),
    blocks=[SequenceOf(SequenceOf(Interval(int, 0), min_len=2, max_len=2), min_len=0), None],
    parameters=[SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0), None],
    method=Options(BLOCK_METHODS), diagonaliser=Options(('auto', 'rbs', 'clifford')),
)
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
    >>> from qdensity.circuits.ansatze import pyramid
    >>> z0 = SparsePauliOp.from_sparse_list([("Z", [0], 1)], 3)
    >>> g = commuting_block_gradient(pyramid(3), z0)
    >>> len(g.blocks), g.num_gradient_circuits
    (3, 5)
    >>> commuting_block_gradient(pyramid(3), z0, method="hadamard").num_gradient_circuits
    3
    """
    params, obs = _check_inputs(circuit, observable, parameters, diagonaliser)
    pset = set(params)
    n = circuit.num_qubits
    if blocks is None:
        blocks = commuting_blocks(circuit, params)
    else:
        blocks = _check_blocks(blocks, circuit, pset)
    circuits: list[QuantumCircuit] = []
    roles: list[str] = []
    values: list[ZStringTable] = []
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
                zip(direct.circuits, direct._values, strict=True)
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
                # ancilla bit 0 -> Y = +1: the ancilla's Z eigenvalue times the system values
                values.append(sys_vals.with_ancilla_z(-2.0 * h * sign))
                continue
            for direction in (1, -1):
                circuits.append(
                    _block_circuit(head, rest, pauli, diag_circ, method, direction)
                )
                roles.append(
                    f"block {b}, term {label} (observable shift {'+' if direction > 0 else '-'})"
                )
                values.append(ZStringTable(sys_vals.z,
                                           direction * h * sign * sys_vals.coefficients))
    return CommutingBlockGradient(
        circuits=circuits,
        parameters=list(params),
        _values=values,
        roles=roles,
        blocks=list(blocks),
        method=method,
    )
