"""Readout mitigation (mthree) with Hamming-weight post-selection on a calibrated snapshot.

Needs the ``ibm`` extra (CI installs it). Oracles: exact statevector values; statistical
comparisons over several fixed seeds with margins; the shots the ledger should hold.
"""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.engines import SamplerEngine
from qdensity.execution.mitigated import mitigated_expectation
from qdensity.execution.plans import measured
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
        # 4 p (1 - p) / (6000 (1 - 2p)^2) per qubit; the calibration estimates p from
        # 3 circuits x 6000 shots per state, adding 4 p (1 - p) / (18000 (1 - 2p)^2). (The
        # engine's own standard error, from the corrected distribution, is near 0 for this
        # basis state and misses both.) 5 sd: false failure 2 x 5.7e-7 over the two seeds.
        p = np.array([tgt.backend.target["measure"][(q,)].error
                      for q in _measured_qubits(eng.compiled(measured(qc)), 3)])[[1, 2]]
        var = np.sum(4 * p * (1 - p) / (1 - 2 * p) ** 2 * (1 / 6000 + 1 / 18000))
        assert abs(fixed.value[0] - 0.0) <= 5 * np.sqrt(var)
        # the raw bias 2 (p_1 - p_2) (-0.15 at manila's qubits 1, 2) is > 10 of its sd away
        # from 0 and 1.5x the bound above
        assert abs(raw.value[0]) > abs(fixed.value[0])
        assert fixed.overhead[0] > 1.0 and raw.overhead[0] == 1.0
        # ledger: one row of 6000 shots twice, plus the calibration circuits' shots
        by = eng.ledger.by_label()
        assert by["mitigated"] == (2, 12000)
        assert by["readout calibration"][1] == 6000 * by["readout calibration"][0] > 0


def test_mitigated_and_postselected_beat_raw_over_seeds():
    tgt = get_target("fake_manila", 4, seed=0)
    qc = unary_loader([0.7, -0.2, 0.5, 0.4]).compose(pyramid(4))
    rows = np.random.default_rng(2).uniform(-1, 1, (3, qc.num_parameters))
    exact = _exact(qc, OBS, rows)
    raw_err, both_err = [], []
    # Over 8 seeds the mean absolute errors were 0.19 (raw, sd 0.015) and 0.049 (mitigated
    # and post-selected, sd 0.016; its gate-noise bias stays): a seed fails 0.6x when the
    # corrected error reaches 0.11, 4 sd, and the mean of three fails 0.5x at 5 sd:
    # false failure ~1e-4 (normal tails of that spread)
    first = 3 * _stat_seed(0)
    for seed in (first, first + 1, first + 2):
        eng = SamplerEngine(target=tgt, seed=seed)
        mit = ReadoutMitigator(tgt, shots=4000, seed=100 + seed, ledger=eng.ledger)
        raw = mitigated_expectation(qc, OBS, rows, engine=eng, shots=4000, postselect=None)
        both = mitigated_expectation(qc, OBS, rows, engine=eng, shots=4000, mitigator=mit)
        assert np.all(raw.kept_fraction == 1.0) and np.all(raw.overhead == 1.0)
        assert np.all((both.kept_fraction > 0.5) & (both.kept_fraction < 1.0))
        assert np.all(both.standard_error > raw.standard_error)  # fewer shots kept, M > 1
        raw_err.append(np.abs(raw.value - exact).mean())
        both_err.append(np.abs(both.value - exact).mean())
        # the raw bias is many standard errors; the corrected one is much smaller
        assert both_err[-1] < 0.6 * raw_err[-1]
    assert np.mean(both_err) < 0.5 * np.mean(raw_err)


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
    se = np.sqrt(sum((a * p.standard_error[0]) ** 2 for a, p in zip(alpha, parts, strict=True)))
    # the error was 0.005 +- 0.01 (gate-noise bias, 6 seeds) with se 0.0106: 5 se + 0.05 is
    # ~9 sd: false failure < 1e-15
    assert abs(value - exact) < 5 * se + 0.05
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
    with pytest.raises(ValueError, match="Hamming weight 1"):
        mitigated_expectation(qc, SparsePauliOp("ZI"), [], engine=eng, shots=10)
    with pytest.raises(TypeError, match="system"):
        ReadoutMitigator("fake_manila")
    with pytest.raises(ValueError, match="not on the device"):
        ReadoutMitigator(tgt).calibrate([7])
