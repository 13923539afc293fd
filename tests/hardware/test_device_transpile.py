"""Transpiling for device targets: the reused preset pass manager against ``qiskit.transpile``,
gate-level output checked by Qiskit's own ``CheckMap`` / ``GatesInBasis`` passes, and the
one-pass resource counts against ``QuantumCircuit.depth`` (issue "Scale", device widths)."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit import transpile as qiskit_transpile
from qiskit.circuit.library import CCXGate
from qiskit.quantum_info import SparsePauliOp
from qiskit.transpiler import PassManager
from qiskit.transpiler.passes import CheckMap, GatesInBasis
from qiskit_aer.noise import NoiseModel

import qdensity.hardware._lazy_noise as lazy_mod
import qdensity.hardware._passmanagers as pm_mod
from qdensity import DensityQNN, Encoding, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.gates import RBSGate
from qdensity.gradients import density_gradient_plan
from qdensity.hardware.resources import _IGNORED, DEFAULT_BASIS, _count, resource_report
from qdensity.hardware.targets import get_target


def _rbs_circuit(n: int, gates: int, seed: int, measure: bool = True) -> QuantumCircuit:
    rng = np.random.default_rng(seed)
    qc = QuantumCircuit(n, name=f"rbs{seed}")
    qc.x(0)
    for _ in range(gates):
        i, j = rng.choice(n, size=2, replace=False)
        qc.append(RBSGate(float(rng.uniform(-3, 3))), [int(i), int(j)])
    if measure:
        qc.measure_all()
    return qc


def _where(tgt) -> dict:
    return ({"target": tgt.target} if tgt.target is not None
            else {"basis_gates": list(tgt.basis_gates)})


@pytest.mark.parametrize("name, n", [("heavy_hex", 7), ("line", 6), ("ideal", 5)])
def test_transpile_equals_qiskit_transpile_in_any_order(name, n):
    # "ideal" with the resource reports' basis: with every standard gate, levels 2 and 3 of
    # qiskit.transpile itself can differ between two calls (equal-cost synthesis choices)
    basis = DEFAULT_BASIS if name == "ideal" else None
    tgt = get_target(name, n, seed=4, noise=False, basis_gates=basis)
    qcs = [_rbs_circuit(n, 6, seed=s) for s in range(4)]
    calls = [(1, None), (3, 9), (1, None), (0, 2), (2, 5)]  # repeats reuse the pass manager
    for level, seed in calls:
        ours = tgt.transpile(qcs, optimization_level=level, seed=seed)
        single = tgt.transpile(qcs[2], optimization_level=level, seed=seed)
        oracle = qiskit_transpile(qcs, optimization_level=level,
                                  seed_transpiler=tgt.seed if seed is None else seed,
                                  **_where(tgt))
        assert ours == oracle and single == oracle[2]
        assert [c.name for c in ours] == [c.name for c in qcs]
        if tgt.coupling_map is not None:
            assert ([c.layout.final_index_layout() for c in ours]
                    == [c.layout.final_index_layout() for c in oracle])


def test_pass_manager_built_once_per_target_level_and_seed(monkeypatch):
    built = []
    original = pm_mod.generate_preset_pass_manager

    def counting(*args, **kwargs):
        built.append((args, kwargs.get("seed_transpiler")))
        return original(*args, **kwargs)

    monkeypatch.setattr(pm_mod, "generate_preset_pass_manager", counting)
    tgt = get_target("line", 4, seed=1, noise=False)
    qc = _rbs_circuit(4, 3, seed=0)
    for _ in range(3):
        tgt.transpile(qc)
        tgt.transpile([qc, qc], optimization_level=2, seed=7)
    assert built == [((1,), 1), ((2,), 7)]
    other = get_target("line", 4, seed=1, noise=False)  # another target: its own
    other.transpile(qc)
    assert len(built) == 3


def test_target_pickles_and_copies_after_transpiling():
    tgt = get_target("heavy_hex", 5, seed=2, noise=False)
    qc = _rbs_circuit(5, 5, seed=3)
    first = tgt.transpile(qc)
    for twin in (pickle.loads(pickle.dumps(tgt)), copy.deepcopy(tgt), copy.copy(tgt)):
        assert twin.transpile(qc) == first


def _density_templates(n: int) -> list[QuantumCircuit]:
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       observable=obs, seed=0)
    x = np.random.default_rng(0).normal(size=(2, n))
    plan = density_gradient_plan(model, x, method="commuting", shots=10)
    return list({id(j.circuit): j.circuit for j in plan.jobs}.values())


@pytest.mark.parametrize("name, n", [("heavy_hex", 8), ("line", 6)])
def test_density_model_templates_compile_to_gate_level_device_circuits(name, n):
    tgt = get_target(name, 19 if name == "heavy_hex" else n, seed=0, noise=False)
    templates = _density_templates(n)
    compiled = tgt.transpile(templates)
    for template, out in zip(templates, compiled, strict=True):
        checks = PassManager([CheckMap(tgt.coupling_map),
                              GatesInBasis(target=tgt.target)])
        checks.run(out)
        assert checks.property_set["is_swap_mapped"] is True
        assert checks.property_set["all_gates_in_basis"] is True
        edges = set(tgt.coupling_map.get_edges())
        pairs = [tuple(out.find_bit(q).index for q in inst.qubits) for inst in out.data
                 if len(inst.qubits) == 2 and inst.operation.name not in _IGNORED]
        assert pairs and all(p in edges for p in pairs)
        assert {i.operation.name for i in out.data} <= set(tgt.basis_gates) | {
            "measure", "barrier"}
        report = resource_report(out, tgt, transpiled=True)
        assert report.two_qubit_count == len(pairs) == out.count_ops().get("cx", 0)
        assert report == resource_report(template, tgt)  # compiled once, the same numbers


def _random_counting_circuit(seed: int) -> QuantumCircuit:
    rng = np.random.default_rng(seed)
    qc = QuantumCircuit(5, 3)
    for _ in range(40):
        kind = rng.integers(7)
        q = [int(v) for v in rng.choice(5, size=3, replace=False)]
        if kind == 0:
            qc.h(q[0])
        elif kind in (1, 2):
            qc.cz(q[0], q[1])
        elif kind == 3:
            qc.append(CCXGate(), q)
        elif kind == 4:
            qc.barrier(q[:2])
        elif kind == 5:
            qc.measure(q[0], int(rng.integers(3)))
        else:
            qc.delay(10, q[0])
    return qc


@pytest.mark.parametrize("seed", range(6))
def test_one_pass_counts_match_quantum_circuit_depth(seed):
    qc = _random_counting_circuit(seed)
    report = _count(qc, name="c", target="t")

    def two_qubit(inst) -> bool:
        return len(inst.qubits) == 2 and inst.operation.name not in _IGNORED

    assert report.depth == qc.depth()
    assert report.two_qubit_depth == qc.depth(filter_function=two_qubit)
    assert report.two_qubit_count == sum(1 for i in qc.data if two_qubit(i))
    assert report.num_qubits == len({qc.find_bit(q).index for i in qc.data for q in i.qubits
                                     if i.operation.name not in _IGNORED})


def test_counts_of_control_flow_circuits_defer_to_qiskit_depth():
    qc = QuantumCircuit(3, 1)
    qc.h(0)
    qc.measure(0, 0)
    with qc.if_test((qc.clbits[0], 1)):
        qc.cx(1, 2)
    qc.cz(0, 2)
    report = _count(qc, name="c", target="t")

    def two_qubit(inst) -> bool:
        return len(inst.qubits) == 2 and inst.operation.name not in _IGNORED

    assert report.depth == qc.depth() == 4
    assert report.two_qubit_depth == qc.depth(filter_function=two_qubit)


def _noise_content(model) -> list:
    """to_dict() without the random per-error ids, for comparing two models."""
    return [{k: v for k, v in err.items() if k != "id"}
            for err in model.to_dict(serializable=True)["errors"]]


def test_noise_model_is_built_on_first_read_and_kept(monkeypatch):
    built = []
    original = lazy_mod.noise_from_backend
    monkeypatch.setattr(lazy_mod, "noise_from_backend", lambda b: built.append(b) or original(b))
    tgt = get_target("heavy_hex", 5, seed=3)
    qc = _rbs_circuit(5, 4, seed=1)
    tgt.transpile(qc)
    resource_report(qc, tgt)
    assert built == [] and "_noise_model" not in repr(tgt)
    twin = pickle.loads(pickle.dumps(tgt))  # pickled before the first read
    model = tgt.noise_model
    assert built == [tgt.backend] and tgt.noise_model is model and tgt.is_noisy
    assert built == [tgt.backend]
    assert _noise_content(model) == _noise_content(NoiseModel.from_backend(tgt.backend))
    assert _noise_content(twin.noise_model) == _noise_content(model)
    assert _noise_content(copy.deepcopy(tgt).noise_model) == _noise_content(model)
    assert tgt.simulator().options.noise_model is model
    with pytest.raises(dataclasses.FrozenInstanceError):
        tgt.noise_model = None
    assert get_target("heavy_hex", 5, noise=False).noise_model is None
    assert not get_target("line", 3, noise=False).is_noisy
