"""Calibrated device snapshots (qiskit-ibm-runtime's fake provider) as named targets.

Needs the ``ibm`` extra (CI installs it). Only two snapshots are loaded: FakeManilaV2 (5 qubits,
simulated) and FakeTorino (133 qubits, listed and transpiled for, never simulated). Oracles: the
snapshot's own calibration (coupling map, native gates, readout error per qubit), exact
expectation values, and the refusal messages.
"""


import numpy as np
import pytest
from _noisy import expected_estimate
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp
from qiskit_ibm_runtime.fake_provider import FakeManilaV2, FakeProviderForBackendV2
from scipy.stats import binom, norm

import qdensity.hardware.snapshots as snapshots
from qdensity.circuits.ansatze import round_robin
from qdensity.cli import build_circuit, main
from qdensity.execution.plans import expectation_plan
from qdensity.execution.sampler.engine import SamplerEngine
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
    # Oracle: the exact noisy expectation of each estimate (tests/_noisy.py: the compiled
    # circuits' density matrices under the snapshot's noise model, then its readout errors).
    # A sample() on the target makes its own engine, whose seeded transpiler may pick
    # another layout (one seed in eight did), so the forward estimate is checked through an
    # engine on the target whose circuits the oracle sees; target= only has to run.
    assert model.train().sample(x, 300, target=tgt, seed=1).shots_used <= 300
    engine = SamplerEngine(target=tgt, seed=_stat_seed(5), progress=False)
    alpha = model.alpha(x[None, :])[0]
    noisy = [expected_estimate(expectation_plan(model.circuit(k), model.observable,
                                                model.rows(k, x[None, :])), engine).value[0]
             for k in range(3)]
    res = model.train().sample(x, 4000, scheduler="proportional", engine=engine,
                               seed=_stat_seed(5))
    # proportional allocation: unbiased for sum_k alpha_k (noisy f_k), a mean of 4000 shots
    # (normal); the noise pulls the value from the exact 0.53 (to 0.49 on layout 0, 1, 2)
    z = norm.isf(0.5e-6)  # each check two-sided at 1e-6, four checks: false failure 4e-6
    assert abs(res.estimate - alpha @ noisy) <= z * res.standard_error
    assert abs(alpha @ noisy - exact) > 0.01 and res.shots_used <= 4000
    engine = SamplerEngine(target=tgt, seed=_stat_seed(3), progress=False)
    plan = density_gradient_plan(model, x[None, :], method="shift", shots=2000)
    grad = plan.run(engine)
    want = expected_estimate(plan, engine)  # shift rules are linear in the frequencies
    # three entries, each a sum of means of 2000 shots (normal), within z se of the oracle
    for js, se, je in zip(grad.jacobians, grad.jacobian_errors, want.jacobians, strict=True):
        assert np.all(np.abs(js - je) <= z * se + 1e-12)
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
