"""Fused blocks of the adjoint engine's compiled kernels against independent oracles.

Fusion runs from 17 qubits in production; here it is switched on at test widths (blocks of at
most 3 qubits, layouts keeping 2 low bits free) so that Qiskit statevectors (values, states)
and their central finite differences (gradients) can check every gate kind inside blocks:
RBS and FBS (parity strings), Qiskit rotations, controlled rotations and phases, Pauli
evolutions and fixed Pauli gates, with dense fixed gates breaking blocks.
"""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.circuit import ParameterVector, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import hardware_efficient
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.execution import _numba
from qdensity.execution.statevector import _kernels
from qdensity.execution.statevector.adjoint import AdjointEngine

pytestmark = pytest.mark.skipif(not _numba.available(), reason="numba switched off")

RNG = np.random.default_rng(20261128)


@pytest.fixture(autouse=True)
def fused(monkeypatch):
    from qdensity.execution.statevector import _layout

    monkeypatch.setattr(_kernels, "FUSE_MIN_QUBITS", 0)
    monkeypatch.setattr(_kernels, "FUSE_LOW_BITS", 2)
    monkeypatch.setattr(_kernels, "FUSE_QUBITS", 3)
    monkeypatch.setattr(_kernels, "FUSE_MIN_GATES", 2)
    monkeypatch.setattr(_layout, "MIN_QUBITS", 0)


def _mixed(n: int) -> QuantumCircuit:
    """RBS, FBS, Qiskit rotations, controlled gates, evolutions, fixed Paulis and a dense
    gate on ``n`` qubits, parameters shared between gates."""
    t = ParameterVector("t", 16)
    qc = QuantumCircuit(n)
    qc.h(range(n))
    for layer in range(2):
        for q in range(n - 1):
            qc.append(RBSGate(t[(q + layer) % 16]), [q, q + 1])
        qc.ry(t[2], 0)
        qc.rz(-t[3] + 0.2, 1)
        qc.rx(t[4], 2)
        qc.crx(t[5], 0, 1)
        qc.cry(t[6], 2, 1)
        qc.crz(t[7], 1, 2)
        qc.append(FBSGate(t[8], 3), [3, 4, 5])
        qc.cx(3, 4)
        qc.cz(4, 5)
        qc.y(3)
        qc.rxx(t[9], 4, 5)
        qc.ryy(t[10], 3, 5)
        qc.rzz(t[11], 3, 4)
        qc.rzx(t[12], 5, 3)
        qc.p(t[13], 4)
        qc.cp(t[14], 3, 5)
        qc.append(PauliEvolutionGate(SparsePauliOp(["XZY", "ZIZ"], [0.7, -0.4]),
                                     time=t[15]), [n - 3, n - 2, n - 1])
        qc.s(2)  # a dense fixed gate: blocks stop at it
        qc.ccx(0, 1, 2)
        qc.append(FBSGate(t[1], 4), [n - 4, n - 3, n - 2, n - 1])  # 4 qubits: never fused
    return qc


def _expectations(qc, observables, values):
    return np.array([[Statevector(qc.assign_parameters(row)).expectation_value(o).real
                      for o in observables] for row in values])


@pytest.mark.parametrize("make", [_mixed, lambda n: hardware_efficient(n, 3, ("ry", "rz"))],
                         ids=["mixed", "hea"])
def test_fused_blocks_match_statevectors_and_finite_differences(make):
    n = 9
    qc = make(n)
    eng = AdjointEngine()
    tab = _kernels.tables(eng.compile(qc))
    assert np.count_nonzero(tab.kind == 4) >= 3  # blocks really run
    assert np.count_nonzero(tab.kind == 3) >= 1  # in a moving layout
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    obs = [SparsePauliOp("X" + "I" * (n - 2) + "Y"),
           SparsePauliOp(["I" * (n - 3) + "ZZI", "Z" + "I" * (n - 1)], [0.4, 0.9])]
    values, jac = eng.value_and_gradient(qc, obs, vals)
    np.testing.assert_allclose(values, _expectations(qc, obs, vals), atol=1e-12)
    eps = 1e-6
    for p in range(qc.num_parameters):
        step = np.zeros(qc.num_parameters)
        step[p] = eps
        fd = (_expectations(qc, obs, vals + step) - _expectations(qc, obs, vals - step)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, p], fd, atol=2e-8)
    for row in range(2):
        ref = Statevector(qc.assign_parameters(vals[row])).data
        got = eng.statevector(qc, vals[row:row + 1])[0]
        phase = np.vdot(got, ref) / abs(np.vdot(got, ref))  # u gates drop a global phase
        np.testing.assert_allclose(got * phase, ref, atol=1e-12)


def test_fused_gradient_wrt_a_subset_stops_inside_blocks():
    """``wrt`` naming parameters whose first rotation sits inside a block: the sweep still
    covers the whole block, and the columns equal those of the full gradient's oracle."""
    n = 9
    qc = _mixed(n)
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    obs = [SparsePauliOp("I" * (n - 1) + "Z")]
    wrt = [12, 3, 15]
    _, jac = AdjointEngine().value_and_gradient(qc, obs, vals, wrt=wrt)
    eps = 1e-6
    for k, p in enumerate(wrt):
        step = np.zeros(qc.num_parameters)
        step[p] = eps
        fd = (_expectations(qc, obs, vals + step) - _expectations(qc, obs, vals - step)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, k], fd, atol=2e-8)


def test_fuse_blocks_keeps_the_order_of_gates_on_a_shared_qubit():
    """Every operation appears once, blocks stay within the width, and any two operations
    that share a qubit keep their circuit order (so the product is unchanged)."""
    from qdensity.execution.statevector._program import compile_program

    ops = _kernels._fuse(compile_program(_mixed(9)).ops)
    items = _kernels.fuse_blocks(ops, 3)
    order = [i for it in items for i in (it if isinstance(it, list) else [it])]
    assert sorted(order) == list(range(len(ops)))
    masks = [_kernels._touched(op) for op in ops]
    for it in items:
        if isinstance(it, list):
            assert bin(np.bitwise_or.reduce([masks[i] for i in it])).count("1") <= 3
    where = {op: k for k, op in enumerate(order)}
    for a in range(len(ops)):
        for b in range(a + 1, len(ops)):
            if masks[a] & masks[b]:
                assert where[a] < where[b]
