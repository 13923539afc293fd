"""Readout mitigation (mthree) with Hamming-weight post-selection on a calibrated snapshot.

Needs the ``ibm`` extra (CI installs it). Oracles: exact statevector values; the exact
expectations of raw and corrected estimates on the noisy device (tests/_noisy.py: density
matrices under its noise model, its readout errors, the calibration's limit); the shots the
ledger should hold.
"""


import numpy as np
import pytest
from _noisy import calibrated_matrices, mitigated_value, noisy_probabilities
from _noisy import measured_qubits as noisy_measured
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector
from scipy.stats import norm

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.observables import diagonal_values
from qdensity.execution.plans import measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.sampler.mitigated import mitigated_expectation
from qdensity.hardware.mitigation import ReadoutMitigator, _measured_qubits, hamming_weights
from qdensity.hardware.targets import get_target
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments

OBS = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("Z", [2], -0.7), ("Z", [3], 0.5)], 4)


def _exact(qc, obs, rows):
    return np.array([np.real(Statevector(qc.assign_parameters(r)).expectation_value(obs))
                     for r in rows])



def test_hamming_weights_brute_force():
    for m in range(1, 6):
        assert hamming_weights(m).tolist() == [bin(b).count("1") for b in range(2**m)]


def test_mitigation_alone_removes_the_readout_bias():
    """A basis state (one X gate): only readout errors matter; mitigated is unbiased."""
    tgt = get_target("fake_manila", seed=0)
    qc = QuantumCircuit(3)
    qc.x(1)
    obs = SparsePauliOp.from_sparse_list([("Z", [1], 1.0), ("Z", [2], 1.0)], 3)
    first = 2 * _stat_seed(0) + 1  # seeds 1, 2; QDENSITY_STAT_SEED=S: 2S + 1, 2S + 2
    for seed in (first, first + 1):
        eng = SamplerEngine(target=tgt, seed=seed)
        mit = ReadoutMitigator(tgt, shots=6000, seed=50 + seed, ledger=eng.ledger)
        raw = mitigated_expectation(qc, obs, [], engine=eng, shots=6000, postselect=None)
        fixed = mitigated_expectation(qc, obs, [], engine=eng, shots=6000, mitigator=mit,
                                      postselect=None)
        # The oracle's spread: Aer flips qubit q's readout with its measure error p_q both
        # ways, so the exact inverse gives sum_q zbar_q / (1 - 2 p_q): sampling variance
        # 4 p (1 - p) / (6000 (1 - 2p)^2) per qubit; the calibration estimates the rate that
        # moves the estimate (1 -> 0 for qubit 1, 0 -> 1 for qubit 2) from one circuit of
        # 6000 shots (mthree calibrates a simulator qubit by qubit), adding as much again.
        # 5 sd: false failure 2 x 5.7e-7 over the two seeds.
        p = np.array([tgt.backend.target["measure"][(q,)].error
                      for q in _measured_qubits(eng.compiled(measured(qc)), 3)])[[1, 2]]
        var = np.sum(4 * p * (1 - p) / (1 - 2 * p) ** 2 * (1 / 6000 + 1 / 6000))
        assert abs(fixed.value[0] - 0.0) <= 5 * np.sqrt(var)
        # the raw bias 2 (p_1 - p_2) (-0.15 at manila's qubits 1, 2) is > 10 of its sd away
        # from 0 and 1.5x the bound above
        assert abs(raw.value[0]) > abs(fixed.value[0])
        assert fixed.overhead[0] > 1.0 and raw.overhead[0] == 1.0
        # ledger: one row of 6000 shots twice, plus the calibration circuits' shots
        by = eng.ledger.by_label()
        assert by["mitigated"] == (2, 12000)
        assert by["readout calibration"][1] == 6000 * by["readout calibration"][0] > 0


def _oracles(eng, circuit, obs, rows, tgt):
    """What raw and mitigated, post-selected estimates converge to (tests/_noisy.py): the
    noisy distribution's value, and its correction by the readout matrices the calibration
    converges to (its X gates' noise included), kept on Hamming weight 1."""
    compiled = eng.compiled(measured(circuit))
    p = noisy_probabilities(compiled, tgt.noise_model, circuit, rows)
    cal = calibrated_matrices(tgt.noise_model, tgt.num_qubits, noisy_measured(compiled))
    h = diagonal_values(obs.paulis, np.real(obs.coeffs), circuit.num_qubits)
    return p @ h, mitigated_value(p, cal, h, hamming_weights(circuit.num_qubits) == 1)


def test_mitigated_and_postselected_beat_raw_over_seeds():
    tgt = get_target("fake_manila", 4, seed=0)
    qc = unary_loader([0.7, -0.2, 0.5, 0.4]).compose(pyramid(4))
    rows = np.random.default_rng(2).uniform(-1, 1, (3, qc.num_parameters))
    exact = _exact(qc, OBS, rows)
    # Each estimate (a mean of 4000 shots, normal) within z se of its oracle: two seeds x
    # three rows x (raw, corrected), each two-sided at 1e-4 / 12: false failure 1e-4
    z = norm.isf(1e-4 / 24)
    first = 2 * _stat_seed(0)
    for seed in (first, first + 1):
        eng = SamplerEngine(target=tgt, seed=seed)
        mit = ReadoutMitigator(tgt, shots=4000, seed=100 + seed, ledger=eng.ledger)
        raw = mitigated_expectation(qc, OBS, rows, engine=eng, shots=4000, postselect=None)
        both = mitigated_expectation(qc, OBS, rows, engine=eng, shots=4000, mitigator=mit)
        assert np.all(raw.kept_fraction == 1.0) and np.all(raw.overhead == 1.0)
        assert np.all((both.kept_fraction > 0.5) & (both.kept_fraction < 1.0))
        assert np.all(both.standard_error > raw.standard_error)  # fewer shots kept, M > 1
        noisy, corrected = _oracles(eng, qc, OBS, rows, tgt)
        assert np.all(np.abs(raw.value - noisy) <= z * raw.standard_error)
        assert np.all(np.abs(both.value - corrected) <= z * both.standard_error)
    # what mitigation and post-selection buy, read off the oracles (no sampling): the mean
    # absolute error 0.19 of the raw values drops to 0.05 (the gate noise that keeps the
    # Hamming weight stays)
    assert np.abs(corrected - exact).mean() < 0.5 * np.abs(noisy - exact).mean()


def test_density_model_output_from_mitigated_subunitaries():
    """What the noise experiment needs: f(x) = sum_k alpha_k f_k(x), each f_k mitigated."""
    n = 3
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, [0.5, 0.3, 0.2], encoding=Encoding.unary(n), seed=2)
    x = np.array([[0.4, -0.9, 0.6]])
    exact = model.predict(x)[0]
    tgt = get_target("fake_manila", n, seed=1)
    eng = SamplerEngine(target=tgt, seed=_stat_seed(7))
    mit = ReadoutMitigator(tgt, seed=_stat_seed(7) + 1, ledger=eng.ledger)
    alpha = model.alpha(x)[0]
    parts = [mitigated_expectation(model.circuit(k), model.observable, model.rows(k, x),
                                   engine=eng, shots=4000, mitigator=mit)
             for k in range(model.num_subunitaries)]
    value = sum(a * p.value[0] for a, p in zip(alpha, parts, strict=True))
    oracle = sum(a * _oracles(eng, model.circuit(k), model.observable, model.rows(k, x),
                              tgt)[1][0] for k, a in enumerate(alpha))
    # the parts share one calibration, so their errors may be correlated: the standard
    # error of the sum is at most the sum of theirs. Normal (means of 4000 shots), two-sided
    # at 1e-6
    se = sum(a * p.standard_error[0] for a, p in zip(alpha, parts, strict=True))
    assert abs(value - oracle) <= norm.isf(0.5e-6) * se
    assert abs(oracle - exact) < 0.05  # gate noise left after the corrections: <= 0.003
    assert all(0.5 < p.kept_fraction[0] <= 1.0 for p in parts)


def test_bad_input():
    tgt = get_target("fake_manila", seed=0)
    eng = SamplerEngine(target=tgt, seed=1)
    qc = QuantumCircuit(2)
    with pytest.raises(ValueError, match="diagonal"):
        mitigated_expectation(qc, SparsePauliOp("XI"), [], engine=eng, shots=10)
    with pytest.raises(ValueError, match="postselect"):
        mitigated_expectation(qc, SparsePauliOp("ZI"), [], engine=eng, shots=10, postselect=3)
    with pytest.raises(TypeError, match="engine"):
        mitigated_expectation(qc, SparsePauliOp("ZI"), [], engine=object(), shots=10)
    with pytest.raises(TypeError, match="mitigator"):
        mitigated_expectation(qc, SparsePauliOp("ZI"), [], engine=eng, shots=10, mitigator=1)
    # |00> read without readout errors: certainly no Hamming-weight-1 outcome to keep (on the
    # noisy device it depends on the draws: a readout flip in 10 shots has probability ~0.4)
    quiet = SamplerEngine(target=get_target("fake_manila", seed=0, noise=False), seed=1)
    with pytest.raises(ValueError, match="Hamming weight 1"):
        mitigated_expectation(qc, SparsePauliOp("ZI"), [], engine=quiet, shots=10)
    with pytest.raises(TypeError, match="system"):
        ReadoutMitigator("fake_manila")
    with pytest.raises(ValueError, match="not on the device"):
        ReadoutMitigator(tgt).calibrate([7])
