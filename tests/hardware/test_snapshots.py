"""Calibrated device snapshots (qiskit-ibm-runtime's fake provider) as named targets.

Needs the ``ibm`` extra (CI installs it). Only two snapshots are loaded: FakeManilaV2 (5 qubits,
simulated) and FakeTorino (133 qubits, listed and transpiled for, never simulated). Oracles: the
snapshot's own calibration (coupling map, native gates, readout error per qubit), exact
expectation values, and the refusal messages.
"""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp
from qiskit_ibm_runtime.fake_provider import FakeManilaV2, FakeProviderForBackendV2
from scipy.stats import binom

import qdensity.hardware.snapshots as snapshots
from qdensity.circuits.ansatze import round_robin
from qdensity.cli import build_circuit, main
from qdensity.execution.engines import ExactEngine, SamplerEngine
from qdensity.gradients.density import density_gradient_plan
from qdensity.hardware.resources import resource_report
from qdensity.hardware.targets import get_target, known_targets
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments


def test_every_fake_v2_backend_is_a_known_target():
    names = {b.name for b in FakeProviderForBackendV2().backends()}
    assert names <= set(known_targets())
    assert {"fake_torino", "fake_manila"} <= names
    assert known_targets()[:6] == ["ideal", "all_to_all", "line", "ring", "heavy_hex",
                                   "rbs_native"]


def test_torino_resource_report_uses_its_coupling_map_and_cz():
    tgt = get_target("fake_torino", 4, noise=False)
    assert tgt.num_qubits == 133 and "cz" in tgt.basis_gates and not tgt.is_noisy
    qc = build_circuit("pyramid", 4)
    report = resource_report(qc, tgt)
    assert report.target == "fake_torino"
    compiled = tgt.transpile(qc)
    edges = set(tgt.backend.coupling_map.get_edges())
    for inst in compiled.data:
        if inst.operation.num_qubits == 2:
            assert inst.operation.name == "cz"
            pair = tuple(compiled.find_bit(q).index for q in inst.qubits)
            assert pair in edges or pair[::-1] in edges
    assert report.two_qubit_count == sum(1 for i in compiled.data if i.operation.num_qubits == 2)



def test_manila_simulator_carries_the_calibrated_readout_error():
    tgt = get_target("fake_manila", seed=4)
    assert tgt.num_qubits == 5 and tgt.is_noisy
    calibrated = [FakeManilaV2().target["measure"][(q,)].error for q in range(5)]
    qc = QuantumCircuit(5)
    qc.measure_all()
    shots = 20000
    counts = tgt.simulator(seed=_stat_seed(9)).run(tgt.transpile(qc, optimization_level=0),
                                       shots=shots).result().get_counts()
    flips = np.zeros(5)
    for key, c in counts.items():
        flips += c * np.array([int(b) for b in key[::-1]])
    rate = flips / shots
    # P(read 1 | prepared 0) against the calibration's average readout error: same order of
    # magnitude (the calibration averages both directions), and never zero
    for q in range(5):
        assert 0 < rate[q] < 3 * calibrated[q] + 5 * np.sqrt(calibrated[q] / shots)
    # and exactly: Aer's noise model from a BackendV2 target flips a readout symmetrically
    # with the target's measure error (nothing else flips a prepared 0), so each qubit's
    # count of 1s is Binomial(20000, calibrated[q]); inside its central 1 - 2e-4 for all 5
    # qubits: false failure 1e-3 (the checks above then hold too)
    for q in range(5):
        p01 = calibrated[q]
        assert binom.ppf(1e-4, shots, p01) <= flips[q] <= binom.isf(1e-4, shots, p01), q


def test_snapshot_target_runs_density_sampling_and_gradient_plans():
    n = 3
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, [0.5, 0.3, 0.2], encoding=Encoding.unary(n), seed=2)
    tgt = get_target("fake_manila", n, seed=1)
    x = np.array([0.4, -0.9, 0.6])
    exact = model.predict(x[None, :])[0]
    res = model.train().sample(x, 4000, scheduler="proportional", target=tgt,
                               seed=_stat_seed(5))
    # noise pulls <Z_0> towards 0: the noisy estimate is close to, but not at, exact. The
    # device bias is -0.045 (mean of 12 seeds, 0.528 -> 0.483) and the sd <= 1 / sqrt(4000)
    # = 0.016: 0.25 is > 12 sd beyond the bias (false failure < 1e-30)
    assert abs(res.estimate - exact) < 0.25 and res.shots_used <= 4000
    engine = SamplerEngine(target=tgt, seed=_stat_seed(3))
    plan = density_gradient_plan(model, x[None, :], method="shift", shots=2000)
    grad = plan.run(engine)
    want = density_gradient_plan(model, x[None, :], method="shift").run(ExactEngine())
    # three entries; the device biases them by 0.02, 0.05 and -0.18 (means of 6 seeds, +-0.01)
    # with standard errors <= 0.026: the largest bias leaves 0.3 at >= 4.6 sd, the others at
    # > 9 sd: false failure < 3e-6
    for js, je in zip(grad.jacobians, want.jacobians, strict=True):
        assert np.max(np.abs(js - je)) < 0.3
    assert engine.ledger.total_shots == plan.total_shots


def test_cli_accepts_snapshot_targets(capsys):
    assert main(["transpile", "pyramid", "--size", "3", "--target", "fake_manila"]) == 0
    assert "fake_manila" in capsys.readouterr().out
    assert main(["transpile", "pyramid", "--size", "6", "--target", "fake_manila"]) == 2
    assert "wider" in capsys.readouterr().err


# ---------------------------------------------------------------------------------- bad input


def test_unknown_snapshot_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown device snapshot 'fake_nowhere'") as info:
        get_target("fake_nowhere")
    assert "fake_manila" in str(info.value) and "fake_torino" in str(info.value)
    with pytest.raises(ValueError, match="known targets:.*fake_manila"):
        get_target("grid", 3)


def test_snapshot_refuses_a_wider_request_and_a_basis():
    with pytest.raises(ValueError, match="num_qubits 6 is wider.*5 qubits"):
        get_target("fake_manila", 6)
    with pytest.raises(ValueError, match="basis_gates"):
        get_target("fake_manila", basis_gates=["cz", "rz"])
    with pytest.raises(ValueError, match="num_qubits is required"):
        get_target("line")
    tgt = get_target("fake_manila", noise=False)
    with pytest.raises(ValueError, match="has 6 qubits but target 'fake_manila' has 5"):
        tgt.transpile(QuantumCircuit(6))


def test_without_the_ibm_extra_other_targets_work(monkeypatch):
    monkeypatch.setattr(snapshots, "snapshots_available", lambda: False)
    assert known_targets() == ["ideal", "all_to_all", "line", "ring", "heavy_hex",
                               "rbs_native"]
    with pytest.raises(ValueError, match=r"qdensity\[ibm\]"):
        get_target("fake_torino")
    est = SamplerEngine(target=get_target("line", 2, seed=1), seed=2)
    qc = QuantumCircuit(2)
    from qdensity.execution.plans import expectation_plan

    value = expectation_plan(qc, SparsePauliOp("ZZ"), [], shots=100).run(est).value[0]
    assert value > 0.5
