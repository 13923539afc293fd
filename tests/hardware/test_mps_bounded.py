"""Wide circuits of bounded entanglement run as matrix-product states (issue "Hardware as
objects", item 3: "wherever the statevector cannot fit and the circuit's entanglement
allows"); wider ones without a proven bound are still refused before allocation.

Oracles: bond bounds counted by hand; the 40-qubit state cos(t/2)|0...0> + sin(t/2)|1...1>
(a rotation and a chain of CNOTs between neighbours), whose only outcomes are the two all-equal
strings, the all-ones one with probability sin(t/2)^2 (a binomial bound at z = 4.4: a false
failure at most 1.1e-5 per run).
"""

import math

import numpy as np
import pytest
from qiskit import QuantumCircuit

from qdensity.execution.plans import CircuitJob
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.aer_sampling import MPS_MAX_BOND, mps_bond_bound

N, THETA, SHOTS = 40, 1.1, 2000  # 40 qubits: a statevector needs 16 TiB


def _chain(n: int, layers: int = 1) -> QuantumCircuit:
    qc = QuantumCircuit(n)
    qc.ry(THETA, 0)
    for _ in range(layers):
        for q in range(n - 1):
            qc.cx(q, q + 1)
    qc.measure_all()
    return qc


def test_bond_bound_by_hand():
    assert mps_bond_bound(_chain(6)) == 2  # one CNOT across every cut
    assert mps_bond_bound(_chain(8, layers=3)) == 8  # three CNOTs across each middle cut
    qc = QuantumCircuit(4)
    qc.h(range(4))
    qc.rxx(0.2, 1, 2)  # rank 4 across the middle cut
    qc.cz(1, 2)
    assert mps_bond_bound(qc) == 4  # 4 * 2 = 8, capped by 2 ** min(2, 2)
    assert mps_bond_bound(QuantumCircuit(3, 3)) == 1  # nothing active: a product state
    qc = QuantumCircuit(8)
    qc.cx(1, 5)  # qubits 1 and 5 are the only active ones: neighbours on their line
    assert mps_bond_bound(qc) == 2
    qc.h(3)
    assert mps_bond_bound(qc) is None  # now 3 sits between them
    qc = QuantumCircuit(3)
    qc.ccx(0, 1, 2)
    assert mps_bond_bound(qc) is None
    with pytest.raises(TypeError, match="circuit must be a QuantumCircuit"):
        mps_bond_bound("cx 0 1")


def test_wide_neighbour_chain_sampled_as_mps():
    engine = SamplerEngine(seed=5, progress=False)
    res = engine.run([CircuitJob(_chain(N), np.empty((1, 0)), SHOTS, "chain")])[0]
    assert res.bits.shape == (1, SHOTS, N)
    ones = res.bits[0].all(axis=1)
    zeros = ~res.bits[0].any(axis=1)
    assert np.all(ones | zeros)  # only the two all-equal strings
    p = math.sin(THETA / 2) ** 2
    assert abs(ones.mean() - p) <= 4.4 * math.sqrt(p * (1 - p) / SHOTS)


def test_wide_circuits_without_a_bound_are_still_refused():
    engine = SamplerEngine(seed=5, progress=False)
    far = QuantumCircuit(N)
    far.ry(THETA, 0)
    far.cx(0, N - 1)  # not neighbours: other active qubits lie between
    for q in range(1, N - 1):
        far.h(q)
    far.measure_all()
    deep = _chain(N, layers=int(math.log2(MPS_MAX_BOND)) + 1)  # 2 ** 9 > 256 at the middle
    for qc in (far, deep):
        with pytest.raises(ValueError, match=r"40 active qubits.*mps_bond_bound"):
            engine.run([CircuitJob(qc, np.empty((1, 0)), 10, "wide")])
