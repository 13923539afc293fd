"""Decompositions of one circuit into sub-unitaries (paper Fig. 3, Fig. 6, Supp. H.1, H.2).

Every decomposition is read off the circuit's gates (via :func:`qdensity.moments`); the
sub-unitaries keep the original ``Parameter`` objects unless they are independent copies, so a
decomposition's parameter count can be compared with the original circuit's.

* :func:`by_moments` -- D consecutive parameterised moments per sub-unitary (round-robin by
  layers gives n - 1, butterfly log2 n, hardware-efficient D).
* :func:`cyclic_moments` -- K = #moments independently parameterised sub-unitaries of D
  cyclically consecutive moments each (round-robin of depth D, Fig. 6).
* :func:`odd_even` -- the odd-even split of the pyramid (Supp. H.1, eq. 27).
* :func:`copies` -- K independently parameterised copies (Fig. 3 right).
* :func:`independent` -- any list of circuits given independent parameter names.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.analysis.parameters import (  # re-exported: the helper lives below the models
    DATA_PREFIX,  # noqa: F401 - imported from here by qdensity.models.density
    trainable_parameters,
)
from qdensity.analysis.structure import moment_indices, moments
from qdensity.circuits._copying import append_owned, assign_fresh, empty_like, gc_paused
from qdensity.validation import (
    MAX_LAYERS,
    MAX_SUBUNITARIES,
    Circuit,
    Instance,
    Interval,
    SequenceOf,
    validates,
)

__all__ = [
    "Decomposition",
    "by_moments",
    "cyclic_moments",
    "odd_even",
    "copies",
    "independent",
    "trainable_parameters",
]


@validates(
    name=Instance(str), sub_unitaries=SequenceOf(Circuit(), max_len=MAX_SUBUNITARIES),
    source=[Circuit(), None], independent=Instance(bool), notes=Instance(dict),
)
@dataclass
class Decomposition:
    """Sub-unitaries obtained from one circuit.

    Attributes
    ----------
    name : str
    sub_unitaries : list of QuantumCircuit
        All of the source's width.
    source : QuantumCircuit or None
        The circuit they were cut from.
    independent : bool
        Whether sub-unitaries have disjoint parameters (Cor. 1) or may share them (Prop. 1).

    Examples
    --------
    The round-robin ansatz on 4 qubits, one sub-unitary per layer: its 6 parameters split 2,
    2, 2, none shared:

    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import by_moments
    >>> dec = by_moments(round_robin(4))
    >>> dec
    Decomposition('round_robin_4_by_moments_1', K=3, params=6, per_subunitary=[2, 2, 2])
    >>> dec.independent, dec.source.num_parameters
    (True, 6)
    """

    name: str
    sub_unitaries: list[QuantumCircuit]
    source: QuantumCircuit | None = None
    independent: bool = True
    notes: dict = field(default_factory=dict)

    @property
    def num_subunitaries(self) -> int:
        """K."""
        return len(self.sub_unitaries)

    @property
    def num_parameters(self) -> int:
        """Distinct trainable parameters over all sub-unitaries."""
        seen = {p for qc in self.sub_unitaries for p in trainable_parameters(qc)}
        return len(seen)

    def parameter_counts(self) -> list[int]:
        """Trainable parameters per sub-unitary."""
        return [len(trainable_parameters(qc)) for qc in self.sub_unitaries]

    def __repr__(self) -> str:
        return (f"Decomposition({self.name!r}, K={self.num_subunitaries}, "
                f"params={self.num_parameters}, per_subunitary={self.parameter_counts()})")


def _groups_to_circuits(circuit: QuantumCircuit, group_of: dict[int, int], count: int,
                        name: str) -> list[QuantumCircuit]:
    """Split ``circuit.data`` into ``count`` circuits; unparameterised gates follow the group of
    the latest parameterised gate on one of their qubits (group 0 before any).

    The instructions are sorted into groups first, then each part is an empty copy of
    ``circuit`` (:func:`qdensity.circuits._copying.empty_like`) with its instructions
    appended, parameterised gates copied (:func:`qdensity.circuits._copying.append_owned`).
    """
    groups: list[list] = [[] for _ in range(count)]
    last_group: dict = {}
    for pos, inst in enumerate(circuit.data):
        g = group_of.get(pos)
        if g is None:
            g = max((last_group.get(q, 0) for q in inst.qubits), default=0)
        else:
            for q in inst.qubits:
                last_group[q] = g
        groups[g].append(inst)
    parts = []
    for k, insts in enumerate(groups):
        part = empty_like(circuit, f"{name}_{k}")
        append_owned(part, insts)
        parts.append(part)
    return parts


def _moment_index(circuit: QuantumCircuit) -> tuple[dict[int, int], int]:
    layers = moment_indices(circuit, include_unparameterised=False)
    return {pos: m for m, layer in enumerate(layers) for pos in layer}, len(layers)


@validates(circuit=Circuit(), depth=Interval(int, 1, MAX_LAYERS), name=[Instance(str), None])
def by_moments(circuit: QuantumCircuit, depth: int = 1, *,
               name: str | None = None) -> Decomposition:
    """D consecutive parameterised moments per sub-unitary (paper Fig. 3 left, Fig. 6 shallow).

    Gates without free parameters (e.g. a hardware-efficient layer's CNOT ladder) stay with the
    sub-unitary of the latest parameterised gate on their qubits.

    Parameters
    ----------
    circuit : QuantumCircuit
        Source circuit, M parameterised moments.
    depth : int
        Moments per sub-unitary, ``1 <= depth <= M``.

    Returns
    -------
    Decomposition
        ``K = ceil(M / depth)`` sub-unitaries sharing the source's parameters (each parameter in
        exactly one sub-unitary when every parameter lives in one moment).

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> by_moments(round_robin(6)).num_subunitaries
    5
    """
    index, count = _moment_index(circuit)
    if count == 0:
        raise ValueError("circuit has no parameterised gates to decompose")
    if depth > count:
        raise ValueError(f"depth must be <= the number of parameterised moments {count}, "
                         f"got {depth}")
    k = -(-count // depth)
    group_of = {key: m // depth for key, m in index.items()}
    with gc_paused():  # a copy of every gate: no garbage cycles
        parts = _groups_to_circuits(circuit, group_of, k, name or circuit.name)
    return Decomposition(name or f"{circuit.name}_by_moments_{depth}", parts, circuit,
                         independent=_disjoint(parts))


def _disjoint(parts: Sequence[QuantumCircuit]) -> bool:
    seen: set = set()
    for qc in parts:
        ps = set(trainable_parameters(qc))
        if seen & ps:
            return False
        seen |= ps
    return True


@validates(circuit=Circuit(), depth=Interval(int, 1, MAX_LAYERS))
def cyclic_moments(circuit: QuantumCircuit, depth: int) -> Decomposition:
    """K = M sub-unitaries of ``depth`` cyclically consecutive moments, independently parameterised.

    Sub-unitary ``k`` holds moments ``k, k+1, ..., k+depth-1 (mod M)`` of the source with fresh
    parameters ``θ{k}``: the round-robin interpolation of Fig. 6 between shallow (``depth=1``,
    ``n/2`` parameters each) and deep (``depth=n-1``, ``n(n-1)/2`` each) experts.

    Parameters
    ----------
    circuit : QuantumCircuit
        Source with M parameterised moments (unparameterised gates are dropped; use it for
        circuits made only of parameterised gates such as the RBS ansätze).
    depth : int
        ``1 <= depth <= M``.

    Returns
    -------
    Decomposition
        ``K = M`` sub-unitaries, ``depth * (gates per moment)`` parameters each.

    Examples
    --------
    Round-robin on 4 qubits has 3 moments of 2 RBS gates; depth 2 gives 3 experts of 4
    fresh parameters each:

    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import cyclic_moments
    >>> cyclic_moments(round_robin(4), 2).parameter_counts()
    [4, 4, 4]
    """
    layers = moments(circuit, include_unparameterised=False)
    m = len(layers)
    if m == 0 or depth > m:
        raise ValueError(f"depth must be between 1 and the number of moments {m}, got {depth}")
    parts = []
    for k in range(m):
        qc = circuit.copy_empty_like(name=f"{circuit.name}_cyclic{depth}_{k}")
        for j in range(depth):
            for inst in layers[(k + j) % m]:
                qc.append(inst)
        parts.append(qc)
    parts = _fresh_parameters(parts)
    return Decomposition(f"{circuit.name}_cyclic_{depth}", parts, circuit, independent=True,
                         notes={"depth": depth})


@validates(circuit=Circuit())
def odd_even(circuit: QuantumCircuit) -> Decomposition:
    """Odd-even split (Supp. H.1, eq. 27): gates whose first qubit is even vs odd.

    For the pyramid every gate of ``U_even`` (and of ``U_odd``) acts on a disjoint or identical
    pair, so each sub-unitary is one commuting block.

    Parameters
    ----------
    circuit : QuantumCircuit
        Typically :func:`qdensity.circuits.ansatze.pyramid`.

    Returns
    -------
    Decomposition
        Two sub-unitaries ``[U_even, U_odd]`` sharing the source's parameters.

    Examples
    --------
    The 4-qubit pyramid's 6 RBS gates: 4 start on an even qubit, 2 on an odd one:

    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.models.decompositions import odd_even
    >>> dec = odd_even(pyramid(4))
    >>> dec.parameter_counts(), dec.num_parameters
    ([4, 2], 6)
    """
    even = circuit.copy_empty_like(name=f"{circuit.name}_even")
    odd = circuit.copy_empty_like(name=f"{circuit.name}_odd")
    for inst in circuit.data:
        first = min(circuit.find_bit(q).index for q in inst.qubits)
        (even if first % 2 == 0 else odd).append(inst)
    return Decomposition(f"{circuit.name}_odd_even", [even, odd], circuit, independent=True)


def _fresh_parameters(circuits: Sequence[QuantumCircuit],
                      prefix: str = "θ") -> list[QuantumCircuit]:
    out = []
    for k, qc in enumerate(circuits):
        params = trainable_parameters(qc)
        vec = ParameterVector(f"{prefix}{k}", len(params))
        # = qc.assign_parameters(mapping, inplace=False), keeping qc's name
        out.append(assign_fresh(qc, dict(zip(params, vec, strict=True))))
    return out


@validates(circuits=SequenceOf(Circuit(), max_len=MAX_SUBUNITARIES), name=Instance(str))
def independent(circuits: Sequence[QuantumCircuit], name: str = "independent") -> Decomposition:
    """Give each circuit its own trainable parameters ``θ{k}`` (data parameters are kept).

    Parameters
    ----------
    circuits : sequence of QuantumCircuit

    Returns
    -------
    Decomposition

    Examples
    --------
    The same circuit twice: with fresh names, twice the parameters:

    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import independent
    >>> dec = independent([round_robin(4), round_robin(4)])
    >>> dec.num_parameters, [p.name for p in dec.sub_unitaries[1].parameters][:2]
    (12, ['θ1[0]', 'θ1[1]'])
    """
    circuits = list(circuits)
    return Decomposition(name, _fresh_parameters(circuits), None, independent=True)


@validates(circuit=Circuit(), num_copies=Interval(int, 1, MAX_SUBUNITARIES))
def copies(circuit: QuantumCircuit, num_copies: int) -> Decomposition:
    """K independently parameterised copies of one circuit (Fig. 3 right, Fig. 6 deep).

    Parameters
    ----------
    circuit : QuantumCircuit
    num_copies : int
        K >= 1.

    Returns
    -------
    Decomposition
        K sub-unitaries with K times the source's parameters.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import copies
    >>> copies(round_robin(4), 3).parameter_counts()
    [6, 6, 6]
    """
    k = int(num_copies)
    dec = independent([circuit] * k, name=f"{circuit.name}_copies_{k}")
    dec.source = circuit
    return dec
