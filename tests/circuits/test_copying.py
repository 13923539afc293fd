"""Building circuits from other circuits' instructions (qdensity.circuits._copying) and the
equivariant model built with it.

Oracles: Qiskit's own ``QuantumCircuit.compose`` / ``copy_empty_like`` /
``assign_parameters(inplace=False)`` compared instruction by instruction, Qiskit ``Operator`` s,
and gate lists built naively from the translation classes enumerated by bit masks (independent
of ``translation_classes``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from qiskit.circuit import (
    ClassicalRegister,
    Parameter,
    ParameterVector,
    QuantumCircuit,
    QuantumRegister,
)
from qiskit.circuit.exceptions import CircuitError
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Operator, SparsePauliOp

from qdensity.circuits._copying import (
    append_owned,
    assign_fresh,
    concatenate,
    empty_like,
    extend,
    fresh_gate,
)
from qdensity.circuits.ansatze import equivariant_commuting, translation_classes
from qdensity.circuits.gates import RBSGate

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


# --------------------------------------------------------------------- extend / concatenate


def rbs_circuit(n: int = 4, prefix: str = "t") -> QuantumCircuit:
    theta = ParameterVector(prefix, 3)
    qc = QuantumCircuit(n, name=f"rbs_{prefix}")
    qc.x(0)
    qc.append(RBSGate(theta[0]), [0, 1])
    qc.append(RBSGate(theta[1]), [2, 1])
    qc.append(RBSGate(np.pi / 4), [1, 3])  # no symbolic parameter: shared, as append shares it
    qc.ry(theta[2], 3)
    return qc


def assert_own_symbolic_gates(a: QuantumCircuit, b: QuantumCircuit) -> None:
    """No gate holding a symbolic parameter is one object in both circuits."""
    ops_a = [i.operation for i in a.data]  # kept alive: ids of live objects only
    ops_b = [i.operation for i in b.data]

    def ids(ops):
        return {id(op) for op in ops if any(hasattr(p, "parameters") for p in op.params)}
    assert ops_a and ops_b and not ids(ops_a) & ids(ops_b)


@pytest.mark.parametrize("second", [rbs_circuit, pauli_circuit])
def test_concatenate_equals_compose(second):
    first = rbs_circuit(4, "s")
    first.global_phase = 0.2
    first.metadata = {"m": 1}
    other = second(3) if second is pauli_circuit else second(4)
    other.global_phase = 0.5
    out = concatenate(first, other)
    ref = first.compose(other)
    assert gates(out) == gates(ref)
    assert out.name == ref.name and out.metadata == ref.metadata
    assert out.parameters[:] == ref.parameters[:]
    assert np.isclose(float(out.global_phase), float(ref.global_phase))
    assert_own_symbolic_gates(out, first)
    assert_own_symbolic_gates(out, other)
    values = values_for(out, 3)
    assert Operator(out.assign_parameters(values)).equiv(Operator(ref.assign_parameters(values)))
    before_first, before_other = gates(first), gates(other)
    out.assign_parameters(values, inplace=True)  # mutating the result leaves both alone
    assert gates(first) == before_first and gates(other) == before_other


def test_extend_on_chosen_qubits_and_other_registers_equals_compose():
    out = QuantumCircuit(QuantumRegister(2, "a"), QuantumRegister(3, "b"))
    ref = out.copy()
    other = rbs_circuit(4)  # its own register "q": bits mapped by position
    extend(out, other, qubits=[4, 0, 3, 1])
    ref.compose(other, qubits=[4, 0, 3, 1], inplace=True)
    assert gates(out) == gates(ref)
    assert_own_symbolic_gates(out, other)
    with pytest.raises(ValueError, match="cannot put 4 qubits"):
        extend(QuantumCircuit(3), other)


def test_extend_with_classical_bits_goes_through_compose():
    other = rbs_circuit(2 + 2)
    other.add_register(ClassicalRegister(1, "c"))
    other.measure(0, 0)
    out, ref = QuantumCircuit(4, 1), QuantumCircuit(4, 1)
    extend(out, other)
    ref.compose(other, inplace=True)
    assert gates(out) == gates(ref)


# ---------------------------------------------------------------- empty_like / append_owned


def test_empty_like_equals_copy_empty_like():
    qc = QuantumCircuit(QuantumRegister(2, "a"), QuantumRegister(1, "b"), ClassicalRegister(2),
                        name="src", global_phase=0.3, metadata={"k": [1]})
    qc.h(0)
    for name in (None, "part"):
        out, ref = empty_like(qc, name), qc.copy_empty_like(name)
        assert out.qregs == ref.qregs and out.cregs == ref.cregs
        assert out.qubits == ref.qubits and out.clbits == ref.clbits
        assert out.name == ref.name and out.global_phase == ref.global_phase
        assert out.metadata == ref.metadata and out.metadata is not qc.metadata
        assert len(out.data) == 0
    loose = QuantumCircuit(2)
    loose.add_bits([type(loose.qubits[0])()])  # a bit outside every register
    out = empty_like(loose)
    assert out.qubits == loose.qubits and len(out.qubits) == 3


def test_append_owned_copies_symbolic_gates_only():
    src = rbs_circuit()
    out = empty_like(src)
    append_owned(out, list(src.data))
    assert gates(out) == gates(src)
    assert_own_symbolic_gates(out, src)
    fixed = [i.operation for i in src.data if i.operation.name == "rbs" and
             not any(hasattr(p, "parameters") for p in i.operation.params)]
    assert any(i.operation is fixed[0] for i in out.data)  # RBS(pi/4): shared, as append does
    out.assign_parameters(values_for(out, 4), inplace=True)
    assert src.num_parameters == 3


# --------------------------------------------------------------------------- fresh gates


@pytest.mark.parametrize("template", [
    PauliEvolutionGate(SparsePauliOp("XZ"), time=Parameter("a")),
    RBSGate(Parameter("a")),
])
def test_fresh_gate_equals_a_new_gate(template):
    b = Parameter("b")
    _ = template.definition  # built: the fresh gate must not keep it
    new = fresh_gate(template, [b])
    assert new.params == [b] and template.params[0].name == "a"
    assert type(new) is type(template) and new.name == template.name
    qc, ref = QuantumCircuit(2), QuantumCircuit(2)
    qc.append(new, [0, 1])
    ref.append(type(template)(template.operator, time=b) if isinstance(template,
               PauliEvolutionGate) else RBSGate(b), [0, 1])
    assert Operator(qc.assign_parameters([0.37])).equiv(Operator(ref.assign_parameters([0.37])))
    qc.assign_parameters([0.1], inplace=True)
    assert template.params[0].name == "a"


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
    assert out.name == qc.name  # the source's name, not Qiskit's counted copy name
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


def test_assign_fresh_of_expressions_phases_and_standard_gates():
    a, b = Parameter("a"), Parameter("b")
    qc = QuantumCircuit(2)
    qc.append(PauliEvolutionGate(SparsePauliOp("XX"), time=2 * a), [0, 1])  # an expression
    out = assign_fresh(qc, {a: b})
    assert gates(out) == gates(qc.assign_parameters({a: b}, inplace=False))
    assert_own_gates(qc, out)
    qc = pauli_circuit()
    qc.global_phase = qc.parameters[0]  # a parameterised phase
    out = assign_fresh(qc, {qc.parameters[0]: b})
    assert out.global_phase == b
    qc = pauli_circuit()
    qc.rz(a, 0)  # a standard gate
    out = assign_fresh(qc, {a: b})
    assert gates(out) == gates(qc.assign_parameters({a: b}, inplace=False))
    with pytest.raises(CircuitError, match="Cannot bind"):
        assign_fresh(pauli_circuit(), {Parameter("absent"): b})


def test_rbs_copies_own_their_parameters_and_rebuild_their_definition():
    import copy

    t = Parameter("t")
    gate = RBSGate(t, label="g")
    _ = gate.definition  # built: a copy rebuilds its own from its parameters
    for cpy in (gate.copy(), copy.deepcopy(gate)):
        assert type(cpy) is RBSGate and cpy is not gate
        assert cpy.params == [t] and cpy.label == "g" and cpy.name == "rbs"
        qc, ref = QuantumCircuit(2), QuantumCircuit(2)
        qc.append(cpy, [0, 1], copy=False)
        ref.h([0, 1])  # the definition written out by hand (paper eq. 8 via two CZs)
        ref.cz(0, 1)
        ref.ry(t, 0)
        ref.ry(-t, 1)
        ref.cz(0, 1)
        ref.h([0, 1])
        assert Operator(qc.decompose().assign_parameters([0.41])).equiv(
            Operator(ref.assign_parameters([0.41])))
        qc.assign_parameters([0.2], inplace=True)  # the copy's parameters are its own
        assert gate.params == [t]
    src = QuantumCircuit(3)
    src.append(RBSGate(t), [0, 2])
    cpy = src.copy()
    cpy.assign_parameters([0.3], inplace=True)
    assert src.parameters[:] == [t]
