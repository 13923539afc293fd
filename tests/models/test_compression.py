"""Merged RBS runs and the compressed odd-even split: operators against the uncompressed ones."""

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter
from qiskit.quantum_info import Operator

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.gates import RBSGate
from qdensity.models.compression import compressed_odd_even, merge_rbs_runs
from qdensity.models.decompositions import odd_even


def _operator(circuit, values):
    return Operator(circuit.assign_parameters(dict(zip(circuit.parameters, values, strict=True))))


@pytest.mark.parametrize("n", [3, 4, 5, 6])
def test_compressed_odd_even_equals_odd_even_with_summed_angles(n):
    rng = np.random.default_rng(n)
    split = odd_even(pyramid(n))
    comp = compressed_odd_even(pyramid(n))
    for k, (sub, merged) in enumerate(zip(split.sub_unitaries, comp.sub_unitaries, strict=True)):
        angles = rng.uniform(-np.pi, np.pi, sub.num_parameters)
        # gate positions and parameter order coincide in the odd-even parts (one angle per gate)
        summed = [angles[g].sum() for g in comp.notes["groups"][k]]
        assert Operator(merged.assign_parameters(summed)).equiv(_operator(sub, angles))


@pytest.mark.parametrize("n", [2, 3, 4, 7, 8])
def test_one_gate_per_pair(n):
    comp = compressed_odd_even(pyramid(n))
    assert comp.parameter_counts() == [n // 2, (n - 1) // 2]
    assert comp.independent and comp.num_parameters == n - 1
    for sub in comp.sub_unitaries:
        pairs = [tuple(sub.find_bit(q).index for q in inst.qubits) for inst in sub.data]
        assert len(pairs) == len(set(pairs))


def test_runs_break_at_other_gates_and_reversed_pairs():
    a, b, c, d = (Parameter(s) for s in "abcd")
    qc = QuantumCircuit(3)
    qc.append(RBSGate(a), [0, 1])
    qc.append(RBSGate(b), [0, 1])   # merges with a
    qc.cx(1, 2)                     # touches qubit 1: ends the run
    qc.append(RBSGate(c), [0, 1])   # new run
    qc.append(RBSGate(d), [1, 0])   # reversed pair: RBS(d) on (1, 0) is not RBS(d) on (0, 1)
    merged, groups = merge_rbs_runs(qc)
    assert groups == [[0, 1], [3], [4]]
    assert merged.count_ops() == {"rbs": 3, "cx": 1}
    vals = [0.3, -1.1, 0.7, 0.25]
    assert Operator(merged.assign_parameters([0.3 - 1.1, 0.7, 0.25])).equiv(
        Operator(qc.assign_parameters(dict(zip([a, b, c, d], vals, strict=True)))))


def test_round_robin_has_nothing_to_merge():
    qc = round_robin(6)
    merged, groups = merge_rbs_runs(qc)
    assert merged.num_parameters == qc.num_parameters
    assert groups == [[i] for i in range(len(qc.data))]
