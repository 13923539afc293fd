"""Readout mitigation and Hamming-weight post-selection as a SamplerEngine option, and engines
that pickle (issue "Hardware as objects", item 2).

Oracles: exact values (statevector / unary amplitudes); the dense correction computed by hand
from the same shots with mthree's ``correct`` (an independent path: a dense count row, not
per-shot weights); a device with readout errors only, where M3 must remove the bias to within
a few standard errors; the ledger's shots by construction.
"""

import pickle

import numpy as np
import pytest
from _stats import stat_seed
from qiskit import QuantumCircuit
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit.quantum_info import SparsePauliOp
from qiskit_aer.noise import NoiseModel, ReadoutError
from qiskit_ibm_runtime.fake_provider import FakeManilaV2
from scipy.stats import norm

from qdensity.circuits.loaders import unary_loader
from qdensity.execution.plans import expectation_plan, probabilities_plan, unary_frequencies
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.mitigation import ReadoutMitigator, _measured_qubits, hamming_weights
from qdensity.hardware.targets import get_target

X = np.array([0.6, 0.8, 0.0, 0.0])
OBS = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("Z", [1], -0.5)], 4)
EXACT = (1 - 2 * 0.36) - 0.5 * (1 - 2 * 0.64)  # <Z0> - 0.5 <Z1> of the unary state


def _readout_only_target(p01=0.12, p10=0.03):
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - p10, p10], [p01, 1 - p01]]))
    return get_target(GenericBackendV2(4, seed=3).target, noise_model=noise)


def test_engine_correction_equals_the_dense_correction_of_the_same_shots():
    qc = unary_loader(X)
    job = expectation_plan(qc, OBS, [], shots=3000).jobs[0]
    raw_engine = SamplerEngine(target=FakeManilaV2(), seed=11, progress=False)
    both = SamplerEngine(target=FakeManilaV2(), seed=11, progress=False, mitigation="m3",
                         postselect="hamming_weight", calibration_shots=2000)
    raw = raw_engine.run([job])[0]
    res = both.run([job])[0]
    assert np.array_equal(raw.bits, res.bits)  # the same shots, only weighted
    # by hand: dense counts, mthree's correct, keep weight-1 outcomes, renormalise
    counts = np.rint(raw.probabilities * 3000)
    mit = ReadoutMitigator(both.target, shots=2000, seed=11)
    quasi, _ = mit.correct(counts, _measured_qubits(raw_engine.compiled(job.circuit), 4))
    keep = hamming_weights(4) == 1
    q = np.where(keep, quasi[0], 0.0)
    q /= q.sum()
    z0 = 1 - 2 * ((np.arange(16) >> 0) & 1)
    z1 = 1 - 2 * ((np.arange(16) >> 1) & 1)
    by_hand = q @ (z0 - 0.5 * z1)
    est = expectation_plan(qc, OBS, [], shots=3000).run(both)
    assert est.value[0] == pytest.approx(by_hand, abs=1e-6)  # mthree solves iteratively
    # unary probabilities from the same weights, against the same dense correction
    p, kept = unary_frequencies(res)
    assert p[0] == pytest.approx(q[1 << np.arange(4)], abs=1e-6)
    assert kept[0] == pytest.approx(1.0)
    labels = both.ledger.by_label()
    circuits, shots = labels["readout calibration"]
    assert shots == circuits * 2000


def test_m3_removes_a_pure_readout_bias_within_its_standard_error():
    tgt = _readout_only_target()
    qc = unary_loader([0.95, 0.2, 0.2, 0.1])
    amps2 = np.array([0.95, 0.2, 0.2, 0.1]) ** 2 / np.sum(np.array([0.95, 0.2, 0.2, 0.1]) ** 2)
    exact = (1 - 2 * amps2[0]) - 0.5 * (1 - 2 * amps2[1])
    errs_raw, z_scores = [], []
    first = 4 * stat_seed(0)  # benchmarks/fuzz_statistics.py
    for seed in range(first, first + 4):
        raw = expectation_plan(qc, OBS, [], shots=4000).run(
            SamplerEngine(target=tgt, seed=seed, progress=False))
        mit = expectation_plan(qc, OBS, [], shots=4000).run(
            SamplerEngine(target=tgt, seed=seed, progress=False, mitigation="m3",
                          calibration_shots=4000))
        errs_raw.append(abs(raw.value[0] - exact))
        z_scores.append((mit.value[0] - exact) / mit.standard_error[0])
        # the mitigation's own uncertainty: its error exceeds the raw one (overhead M > 1)
        assert mit.standard_error[0] > raw.standard_error[0]
    # the readout bias: each raw <Z_q> is (e1 - e0) + (1 - e0 - e1) <Z_q> (e0 = 0.03, e1 = 0.12),
    # so the raw value is off by 0.237 with a per-run sd of 0.014 (exact over the flipped
    # outcomes): 0.05 is 13 sd away (false failure < 1e-38)
    assert min(errs_raw) > 0.05
    # mitigated z-scores: normal with sd 1 (the engine's delta-method error over the shots and
    # the calibration; test_mitigated_errors.py checks it against the spread over seeds):
    # false failure 4 x 2 Phi(-4) = 2.5e-4
    assert max(abs(z) for z in z_scores) < 4


def test_postselection_on_a_noiseless_engine_changes_nothing():
    qc = unary_loader(X)
    plain = probabilities_plan(qc, [], shots=500).run(SamplerEngine(seed=2, progress=False))
    post = probabilities_plan(qc, [], shots=500).run(
        SamplerEngine(seed=2, progress=False, postselect="hamming_weight"))
    assert np.array_equal(plain.bits, post.bits)
    assert np.allclose(post.weights, 1.0) and np.allclose(post.effective_shots, 500)


def test_gradient_plans_use_the_engine_mitigation():
    from qdensity import DensityQNN, Encoding, by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.execution.exact import ExactEngine
    from qdensity.gradients import density_gradient_plan

    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4)
    model = DensityQNN(by_moments(round_robin(4)).sub_unitaries[:2], encoding=Encoding.unary(4),
                       observable=obs, seed=1)
    x = np.array([[0.9, 0.3, 0.2, 0.1]])
    exact = density_gradient_plan(model, x, method="commuting").run(ExactEngine())
    tgt = _readout_only_target(p01=0.12, p10=0.03)
    plan = density_gradient_plan(model, x, method="commuting", shots=4000)
    seed = stat_seed(5)
    mit = plan.run(SamplerEngine(target=tgt, seed=seed, progress=False, mitigation="m3"))
    raw = plan.run(SamplerEngine(target=tgt, seed=seed, progress=False))
    # Oracles: mitigated values centre on the exact ones; raw outputs on the exact ones as
    # the readout error moves them, <Z_0> -> (p01 - p10) + (1 - p01 - p10) <Z_0>. Every
    # estimate averages 4000 shots (normal); the checks are six entries (two outputs and two
    # nonzero Jacobian entries mitigated, two raw outputs; the other two Jacobian entries'
    # estimators are identically 0, se 0), each two-sided at 1e-3 / 6: false failure 1e-3.
    z = norm.isf(1e-3 / 12)
    pairs = [(mit.outputs, mit.output_errors, exact.outputs),
             (raw.outputs, raw.output_errors, 0.09 + 0.85 * exact.outputs)]
    pairs += list(zip(mit.jacobians, mit.jacobian_errors, exact.jacobians, strict=True))
    for est, se, want in pairs:
        assert np.all(np.abs(est - want) <= z * se + 1e-12)
    # the raw bias of the first output, 0.09 - 0.15 (-0.67) = 0.19, is > 13 raw se (0.014)


def test_readouts_the_correction_cannot_handle_are_refused():
    qc = QuantumCircuit(2)
    qc.h(0)
    with pytest.raises(ValueError, match=r"mitigation must be 'm3' or None"):
        SamplerEngine(seed=0, mitigation="zne")
    with pytest.raises(TypeError, match=r"postselect must be 'hamming_weight' or None"):
        SamplerEngine(seed=0, postselect=1)
    with pytest.raises(ValueError, match="needs a device to calibrate"):
        SamplerEngine(seed=0, mitigation="m3")
    engine = SamplerEngine(seed=0, postselect="hamming_weight", progress=False)
    with pytest.raises(ValueError, match=r"gate 'h' does not keep the Hamming weight.*rbs"):
        probabilities_plan(qc, [], shots=10).run(engine)
    with pytest.raises(ValueError, match="Hamming weight"):  # an X observable rotates the basis
        expectation_plan(unary_loader(X), SparsePauliOp("IIIX"), [], shots=10).run(engine)
    assert engine.ledger.total_shots == 0


def test_engine_pickles_and_repeats_its_counts():
    qc = unary_loader(X)
    plan = expectation_plan(qc, OBS, [], shots=300)
    for engine in (SamplerEngine(target=FakeManilaV2(), seed=4, progress=False, mitigation="m3",
                                 postselect="hamming_weight", calibration_shots=500),
                   SamplerEngine(seed=4, progress=False)):
        copy = pickle.loads(pickle.dumps(engine))
        assert copy.mitigation == engine.mitigation and copy.postselect == engine.postselect
        a, b = engine.run(plan.jobs)[0], copy.run(plan.jobs)[0]
        assert np.array_equal(a.bits, b.bits)
        assert plan.run(engine).value == pytest.approx(plan.run(copy).value, abs=1e-12)


def test_estimator_trains_and_predicts_through_a_mitigated_engine():
    from qdensity import QNNClassifier

    # small on purpose (4 rows, one batch, 100 calibration shots): what is checked is the
    # path (calibration once, every training row at the estimator's shots, labels out)
    rng = np.random.default_rng(0)
    X = rng.normal(size=(4, 4))
    y = np.array([0, 1, 0, 1])
    engine = SamplerEngine(target=FakeManilaV2(), seed=1, progress=False, mitigation="m3",
                           postselect="hamming_weight", calibration_shots=100)
    clf = QNNClassifier(num_qubits=4, engine=engine, shots=32, epochs=1, batch_size=4,
                        verbose=False, seed=0).fit(X, y)
    labels = engine.ledger.by_label()
    cal_circuits, cal_shots = labels.pop("readout calibration")
    assert cal_circuits > 0 and cal_shots == 100 * cal_circuits
    # every other ledger entry is a training circuit row at 32 shots
    assert labels and all(shots == 32 * circuits for circuits, shots in labels.values())
    assert set(clf.predict(X)) <= {0, 1}


def test_sample_calibrates_once_per_call():
    """A Neyman call runs a pilot and a main phase on two fresh engines: one calibration."""
    from qdensity import DensityQNN, Encoding, by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.execution.sampler.engine import ShotLedger

    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], 4)
    model = DensityQNN(by_moments(round_robin(4)).sub_unitaries[:2], encoding=Encoding.unary(4),
                       observable=obs, seed=1).train()
    ledger = ShotLedger()
    res = model.sample([0.9, 0.3, 0.2, 0.1], 400, scheduler="neyman",
                       target=_readout_only_target(), seed=3, mitigation="m3",
                       postselect="hamming_weight", ledger=ledger)
    by = ledger.by_label()
    # one calibration of the device's 4 qubits: mthree calibrates a simulator qubit by qubit,
    # one circuit preparing |0> and one preparing |1>, 4000 shots each (the engine default)
    assert by.pop("readout calibration") == (8, 8 * 4000)
    assert any(label.startswith("pilot") for label in by)  # both phases ran
    assert sum(shots for _, shots in by.values()) == res.shots_used
    with pytest.raises(ValueError, match="ledger is for the fresh engines"):
        model.sample([0.9, 0.3, 0.2, 0.1], 400, engine=SamplerEngine(seed=0, progress=False),
                     ledger=ledger)
