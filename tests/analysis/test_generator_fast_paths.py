"""Fast paths of the commuting analysis against Qiskit's own operations and brute force."""

import numpy as np
import pytest
from qiskit.circuit import QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import Clifford, Operator, PauliList, SparsePauliOp, random_clifford

from qdensity.analysis._gf2 import span_basis
from qdensity.analysis.blocks import _evolve, _first_noncommuting
from qdensity.analysis.pauli import anticommutation, first_noncommuting_pair
from qdensity.analysis.structure import _placed, instruction_generator
from qdensity.circuits.ansatze import equivariant_commuting, translation_classes
from qdensity.gradients._direct import _evolve_all


def test_placed_matches_apply_layout():
    rng = np.random.default_rng(3)
    for _ in range(20):
        k, n = rng.integers(1, 4), 6
        labels = ["".join(rng.choice(list("IXYZ"), size=k)) for _ in range(rng.integers(1, 4))]
        op = SparsePauliOp(labels, rng.normal(size=len(labels)) + 1j * rng.normal(size=len(labels)))
        qubits = [int(q) for q in rng.permutation(n)[:k]]
        assert _placed(op, qubits, n) == op.apply_layout(qubits, n)


def test_instruction_generator_pauli_evolution_exponentiates_to_gate():
    qc = QuantumCircuit(4)
    qc.append(PauliEvolutionGate(SparsePauliOp(["XY", "ZZ"], [0.3, -0.2]), time=0.7), [3, 1])
    gen = instruction_generator(qc.data[0], qc).to_matrix()
    w, v = np.linalg.eigh(gen)
    assert np.allclose(v @ np.diag(np.exp(-0.7j * w)) @ v.conj().T, Operator(qc).data)


def test_span_basis_commutation_matches_pairwise():
    rng = np.random.default_rng(5)
    for trial in range(30):
        n, m = 5, int(rng.integers(2, 12))
        if trial % 2:  # a commuting family: products of Z strings conjugated by a Clifford
            pl = PauliList.from_symplectic(rng.random((m, n)) < 0.5, np.zeros((m, n), bool))
            pl = pl.evolve(random_clifford(n, seed=trial), frame="s")
        else:
            pl = PauliList.from_symplectic(rng.random((m, n)) < 0.4, rng.random((m, n)) < 0.4)
        pairwise = not anticommutation(pl.x, pl.z).any()
        assert (not anticommutation(*span_basis(pl.x, pl.z)).any()) == pairwise
        gens = [SparsePauliOp(pl[i]) for i in range(m)]
        brute = next(((a, b) for a in range(m) for b in range(a + 1, m)
                      if not pl[a].commutes(pl[b])), None)
        assert _first_noncommuting(gens) == brute
        assert first_noncommuting_pair(pl) == brute  # the span test first, then the pairs


def test_evolve_all_matches_one_by_one():
    cliff = Clifford(random_clifford(3, seed=1))
    ops = {"a": SparsePauliOp(["XY", "ZI"], [0.5, 1j]), "b": SparsePauliOp(["YZ"], [2.0])}
    ops = {p: op.apply_layout([0, 2], 3) for p, op in ops.items()}
    got = _evolve_all(ops, cliff, 3)
    for p, op in ops.items():
        assert got[p] == _evolve(op, cliff, [0, 1, 2]).simplify()


def test_equivariant_circuit_is_one_evolution_per_string():
    n = 6
    qc = equivariant_commuting(n, "Y", max_weight=3)
    supports = [s for cls in translation_classes(n, 3) for s in cls]
    assert len(qc.data) == len(supports)
    theta = qc.parameters
    for inst, s in zip(qc.data, supports, strict=True):
        assert [qc.find_bit(q).index for q in inst.qubits] == list(s)
        assert inst.operation.operator == SparsePauliOp("Y" * len(s))
    # classes: brute force over all n shifts
    for cls in translation_classes(n, 3):
        orbit = {tuple(sorted((q + t) % n for q in cls[0])) for t in range(n)}
        assert set(cls) == orbit
    assert qc.num_parameters == len(theta) == len(translation_classes(n, 3))


def test_block_reader_matches_instruction_generator_per_gate():
    """The batched reader (templates placed by numpy indexing, coefficients without symbolic
    gradients) against instruction_generator and parameter_of, gate by gate; and through
    Cliffords against _evolve applied one gate at a time."""
    from qiskit.circuit import Parameter

    from qdensity.analysis.blocks import _analyse_block, _clifford_of
    from qdensity.analysis.structure import parameter_of
    from qdensity.circuits.gates import FBSGate, RBSGate

    a, b, c, d = (Parameter(s) for s in "abcd")
    params = {a, b, c, d}
    qc = QuantumCircuit(5)
    qc.append(PauliEvolutionGate(SparsePauliOp(["XY", "ZZ"], [0.3, -0.2]), time=2 * a + 1),
              [3, 1])
    qc.append(PauliEvolutionGate(SparsePauliOp(["XY", "ZZ"], [0.3, -0.2]), time=b), [0, 4])
    qc.append(RBSGate(c), [2, 0])
    qc.append(FBSGate(d, 3), [1, 2, 4])
    qc.rzz(-0.5 * a, 0, 3)
    qc.cp(b, 2, 3)
    qc.crx(c, 4, 1)
    qc.ry(d, 2)
    for inst in qc.data:  # each gate alone: a one-gate block ending the circuit
        single = QuantumCircuit(5)
        single.append(inst)
        (t,) = _analyse_block(single, 0, 1, params)
        assert (t.parameter, t.coeff) == parameter_of(inst)
        assert t.generator == instruction_generator(single.data[0], single).simplify()
        assert t.label.startswith(inst.operation.name)
    # a commuting (Z-type) block through Cliffords that keep it Z-type
    blk = QuantumCircuit(4)
    blk.h(0)  # state preparation
    blk.append(PauliEvolutionGate(SparsePauliOp(["ZZ", "IZ"], [0.5, 0.25]), time=a), [0, 2])
    blk.cx(0, 1)
    blk.rzz(3 * b, 1, 3)
    blk.s(2)
    blk.cp(c, 3, 0)
    blk.cz(1, 2)
    blk.append(PauliEvolutionGate(SparsePauliOp(["ZZ", "IZ"], [0.5, 0.25]), time=d), [3, 1])
    blk.cx(2, 3)
    expect = []
    for inst in blk.data[1:]:
        po = parameter_of(inst)
        if po is not None:
            expect.append((po, instruction_generator(inst, blk).simplify()))
            continue
        cliff, qubits = _clifford_of(inst), [blk.find_bit(q).index for q in inst.qubits]
        expect = [(p, _evolve(g, cliff, qubits)) for p, g in expect]
    got = _analyse_block(blk, 1, len(blk.data), params)
    assert [(t.parameter, t.coeff) for t in got] == [p for p, _ in expect]
    for t, (_, g) in zip(got, expect, strict=True):
        assert t.generator == g


def test_equivariant_builder_matches_plain_construction():
    from qiskit.circuit import ParameterVector

    for n, pauli in [(5, "X"), (6, "Y")]:
        qc = equivariant_commuting(n, pauli)
        theta = ParameterVector("θ", len(translation_classes(n, 3)))
        ref = QuantumCircuit(n, name=qc.name)
        for cls, t in zip(translation_classes(n, 3), theta, strict=True):
            for s in cls:
                ref.append(PauliEvolutionGate(SparsePauliOp(pauli * len(s)), time=t), s)
        assert qc.assign_parameters(list(range(len(theta)))) == ref.assign_parameters(
            list(range(len(theta))))
        ops = [inst.operation for inst in qc.data]
        assert len({id(op) for op in ops}) == len(ops)
        assert len({id(op.params) for op in ops}) == len(ops)


def test_block_of_shared_pauli_evolutions_matches_instruction_generator():
    """The run of Pauli evolutions sharing operators and Parameter objects (the equivariant
    models and their copies) read without the reader's dispatch, against instruction_generator
    and parameter_of gate by gate; data and fixed times are not trainable."""
    from qiskit.circuit import ParameterVector

    from qdensity.analysis.blocks import _analyse_block
    from qdensity.analysis.parameters import trainable_parameters
    from qdensity.analysis.structure import parameter_of
    from qdensity.models.decompositions import copies

    x = ParameterVector("x", 2)
    model = equivariant_commuting(6, "X")
    for qc in [model, *copies(model, 2).sub_unitaries]:
        circ = QuantumCircuit(6)
        zz = SparsePauliOp("ZZ")
        circ.append(PauliEvolutionGate(zz, time=x[0]), [0, 1])  # data: state preparation
        circ.append(PauliEvolutionGate(zz, time=0.4), [2, 3])  # fixed: state preparation
        circ.compose(qc, inplace=True)
        circ.append(PauliEvolutionGate(zz, time=x[1]), [4, 5])  # data after the block
        params = set(trainable_parameters(circ))
        got = _analyse_block(circ, 2, len(circ.data) - 1, params)
        data = circ.data[2:-1]
        assert [t.index for t in got] == list(range(2, len(circ.data) - 1))
        for t, inst in zip(got, data, strict=True):
            assert t.name == "PauliEvolution"
            assert (t.parameter, t.coeff) == parameter_of(inst)
            assert t.generator == instruction_generator(inst, circ).simplify()
        with pytest.raises(ValueError, match="neither trainable nor Clifford"):
            _analyse_block(circ, 2, len(circ.data), params)
