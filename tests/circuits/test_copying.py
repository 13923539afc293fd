"""Cheap copies of Pauli-evolution circuits (qdensity.circuits._copying) and the equivariant
model built with them.

Oracles: Qiskit's own ``QuantumCircuit.copy`` / ``assign_parameters(inplace=False)`` compared
instruction by instruction, Qiskit ``Operator`` s, and gate lists built naively from the
translation classes enumerated by bit masks (independent of ``translation_classes``).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from qiskit.circuit import Parameter, ParameterVector, QuantumCircuit
from qiskit.circuit.exceptions import CircuitError
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Operator, SparsePauliOp

from qdensity.circuits._copying import assign_fresh, copy_circuit
from qdensity.circuits.ansatze import equivariant_commuting, translation_classes

pytestmark = pytest.mark.filterwarnings("ignore::scipy.sparse.SparseEfficiencyWarning")


def necklaces(n: int, k: int) -> int:
    """Burnside: binary necklaces of length n with k ones."""
    total = sum(sum(1 for j in range(1, d + 1) if math.gcd(j, d) == 1)
                * math.comb(n // d, k // d)
                for d in range(1, n + 1) if n % d == 0 and k % d == 0)
    assert total % n == 0
    return total // n


def mask_classes(n: int, k: int) -> list[list[tuple[int, ...]]]:
    """Orbits of k-subsets under rotation, from bit masks; ordered by smallest member."""
    full = (1 << n) - 1
    seen: set[int] = set()
    orbits = []
    for support in _k_subsets(n, k):
        mask = sum(1 << q for q in support)
        if mask in seen:
            continue
        orbit = {((mask << s) | (mask >> (n - s))) & full for s in range(n)}
        seen |= orbit
        orbits.append(sorted(tuple(q for q in range(n) if (m >> q) & 1) for m in orbit))
    return sorted(orbits, key=lambda o: o[0])


def _k_subsets(n: int, k: int):
    if k == 0:
        yield ()
        return
    for first in range(n - k + 1):
        for rest in _k_subsets(n - first - 1, k - 1):
            yield (first,) + tuple(first + 1 + q for q in rest)


def gates(circuit: QuantumCircuit) -> list[tuple]:
    """Each instruction as (type, name, params, qubit indices, clbit indices, operator)."""
    out = []
    for inst in circuit.data:
        op = inst.operation
        operator = getattr(op, "operator", None)
        out.append((type(op), op.name, list(op.params),
                    [circuit.find_bit(q).index for q in inst.qubits],
                    [circuit.find_bit(c).index for c in inst.clbits],
                    None if operator is None else (operator.paulis.to_labels(),
                                                   operator.coeffs.tolist())))
    return out


def assert_own_gates(a: QuantumCircuit, b: QuantumCircuit) -> None:
    """No gate object or parameter list shared between the two circuits."""
    ops_a = [i.operation for i in a.data]  # kept alive: ids of live objects only
    ops_b = [i.operation for i in b.data]
    assert not {id(op) for op in ops_a} & {id(op) for op in ops_b}
    assert not {id(op._params) for op in ops_a} & {id(op._params) for op in ops_b}


def pauli_circuit(n: int = 3) -> QuantumCircuit:
    theta = ParameterVector("θ", 3)
    qc = QuantumCircuit(n, name="paulis")
    qc.append(PauliEvolutionGate(SparsePauliOp("XY"), time=theta[0]), [0, 2])
    qc.append(PauliEvolutionGate(SparsePauliOp(["ZZ", "XX"], [0.5, 1.0]), time=theta[1]), [1, 2])
    qc.append(PauliEvolutionGate(SparsePauliOp("Y"), time=0.3), [1])
    qc.append(PauliEvolutionGate(SparsePauliOp("Z"), time=theta[2]), [0])
    return qc


def values_for(circuit: QuantumCircuit, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    return {p: float(v) for p, v in zip(circuit.parameters,
                                        rng.uniform(-1, 1, circuit.num_parameters),
                                        strict=True)}


# ------------------------------------------------------------------- translation classes


@pytest.mark.parametrize("n", range(2, 17))
def test_classes_equal_the_bit_mask_orbits(n):
    k_max = min(n, 4)
    expected = [c for k in range(1, k_max + 1) for c in mask_classes(n, k)]
    assert translation_classes(n, k_max) == expected


@pytest.mark.parametrize("n", range(2, 25))
def test_class_counts_are_the_burnside_necklace_counts(n):
    classes = translation_classes(n, min(n, 5))
    for k in range(1, min(n, 5) + 1):
        assert sum(len(c[0]) == k for c in classes) == necklaces(n, k)
        assert sum(len(c) for c in classes if len(c[0]) == k) == math.comb(n, k)


@pytest.mark.parametrize(("n", "k"), [(16, 16), (17, 15), (17, 16), (18, 17)])
def test_classes_of_heavy_supports(n, k):
    """k log2(n) >= 62: the canonical forms are grouped row-wise, not by one integer."""
    classes = [c for c in translation_classes(n, k) if len(c[0]) == k]
    assert classes == mask_classes(n, k)
    assert len(classes) == necklaces(n, k)


def test_classes_hold_python_ints():
    for cls in translation_classes(9, 3):
        for support in cls:
            assert type(support) is tuple and all(type(q) is int for q in support)


# ------------------------------------------------------------------------ the XX/YY model


@pytest.mark.parametrize("n", [8, 10, 12])
@pytest.mark.parametrize("pauli", ["X", "Y"])
def test_model_gates_are_one_evolution_per_string_of_each_class(n, pauli):
    qc = equivariant_commuting(n, pauli, max_weight=3)
    classes = [c for k in (1, 2, 3) for c in mask_classes(n, k)]
    theta = {p.index: p for p in qc.parameters}  # the model's own vector θ
    assert [theta[c].name for c in range(len(classes))] == [f"θ[{c}]" for c in range(len(classes))]
    expected = []
    for c, cls in enumerate(classes):
        for support in cls:
            expected.append((PauliEvolutionGate, "PauliEvolution", [theta[c]], list(support), [],
                             ([pauli * len(support)], [1.0])))
    assert gates(qc) == expected
    assert len({id(i.operation) for i in qc.data}) == len(qc.data)
    assert len({id(i.operation._params) for i in qc.data}) == len(qc.data)
    assert all(i.operation._definition is None for i in qc.data)


def test_model_gates_are_independent_of_each_other():
    qc = equivariant_commuting(5, "X", max_weight=2)
    first, second = qc.data[0].operation, qc.data[1].operation  # same class, same parameter
    assert first.params == second.params
    qc.assign_parameters({qc.parameters[0]: 0.25}, inplace=True)
    assert [i.operation.params for i in qc.data[:5]] == [[0.25]] * 5
    assert first is not second


# ------------------------------------------------------------------------------- copying


@pytest.mark.parametrize("make", [pauli_circuit, lambda: equivariant_commuting(6, "Y")])
def test_copy_equals_qiskit_copy_and_owns_its_gates(make):
    qc = make()
    cpy = copy_circuit(qc)
    ref = qc.copy()
    assert gates(cpy) == gates(ref) == gates(qc)
    assert cpy.name == qc.name and cpy.parameters[:] == qc.parameters[:]
    assert_own_gates(qc, cpy)
    values = values_for(qc, 1)
    assert Operator(cpy.assign_parameters(values)).equiv(Operator(qc.assign_parameters(values)))
    before = gates(qc)
    cpy.assign_parameters(values, inplace=True)  # mutating the copy leaves the source alone
    assert gates(qc) == before
    assert cpy.num_parameters == 0 and qc.num_parameters == len(values)
    cpy2 = copy_circuit(qc)
    qc.assign_parameters(values, inplace=True)  # and the other way round
    assert cpy2.num_parameters == len(values)


def test_copy_of_other_gates_goes_through_qiskit():
    theta = Parameter("t")
    qc = pauli_circuit()
    qc.rx(theta, 0)  # a standard gate: not a plain Pauli evolution
    cpy = copy_circuit(qc)
    assert gates(cpy) == gates(qc)
    assert_own_gates(qc, cpy)
    cpy.assign_parameters({theta: 0.5}, inplace=True)
    assert theta in qc.parameters
    # a Pauli evolution whose definition is built is copied by Qiskit (with the definition)
    qc = pauli_circuit()
    _ = qc.data[0].operation.definition
    cpy = copy_circuit(qc)
    assert cpy.data[0].operation._definition is not None
    assert cpy.data[0].operation._definition is not qc.data[0].operation._definition
    assert gates(cpy) == gates(qc)
    assert_own_gates(qc, cpy)


def test_copy_keeps_registers_phase_and_metadata():
    qc = pauli_circuit()
    qc.global_phase = 0.7
    qc.metadata = {"a": [1]}
    cpy = copy_circuit(qc)
    assert cpy.global_phase == 0.7 and cpy.metadata == {"a": [1]}
    assert cpy.metadata is not qc.metadata
    assert cpy.qregs == qc.qregs and cpy.qubits == qc.qubits


# ----------------------------------------------------------------- fresh parameters at once


@pytest.mark.parametrize("make", [pauli_circuit, lambda: equivariant_commuting(6, "X")])
def test_assign_fresh_equals_assign_parameters(make):
    qc = make()
    fresh = ParameterVector("φ", qc.num_parameters)
    mapping = dict(zip(qc.parameters, fresh, strict=True))
    out = assign_fresh(qc, mapping)
    ref = qc.assign_parameters(mapping, inplace=False)
    assert gates(out) == gates(ref)
    assert out.parameters[:] == ref.parameters[:] == list(fresh)
    # named as Qiskit names the copy: the base name and a count of circuits made
    assert re.fullmatch(rf"{qc.name}-\d+", out.name) and re.fullmatch(rf"{qc.name}-\d+", ref.name)
    assert_own_gates(qc, out)
    values = values_for(out, 2)
    back = {p: values[mapping[p]] for p in qc.parameters}
    assert Operator(out.assign_parameters(values)).equiv(Operator(qc.assign_parameters(back)))
    before = gates(qc)
    out.assign_parameters(values, inplace=True)
    assert gates(qc) == before


def test_assign_fresh_partial_mapping_keeps_the_other_parameters():
    qc = pauli_circuit()
    new = Parameter("new")
    out = assign_fresh(qc, {qc.parameters[0]: new})
    assert gates(out) == gates(qc.assign_parameters({qc.parameters[0]: new}, inplace=False))


def test_assign_fresh_falls_back_to_qiskit():
    a, b = Parameter("a"), Parameter("b")
    qc = QuantumCircuit(2)
    qc.append(PauliEvolutionGate(SparsePauliOp("XX"), time=2 * a), [0, 1])  # an expression
    out = assign_fresh(qc, {a: b})
    assert gates(out) == gates(qc.assign_parameters({a: b}, inplace=False))
    assert_own_gates(qc, out)
    qc = pauli_circuit()
    qc.global_phase = qc.parameters[0]  # a parameterised phase
    mapping = {qc.parameters[0]: b}
    out = assign_fresh(qc, mapping)
    assert out.global_phase == b
    qc = pauli_circuit()
    qc.rz(a, 0)  # a standard gate
    out = assign_fresh(qc, {a: b})
    assert gates(out) == gates(qc.assign_parameters({a: b}, inplace=False))
    with pytest.raises(CircuitError, match="Cannot bind"):
        assign_fresh(pauli_circuit(), {Parameter("absent"): b})
