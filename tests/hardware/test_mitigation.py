"""Readout mitigation (mthree) with Hamming-weight post-selection on a calibrated snapshot.

Needs the ``ibm`` extra (CI installs it). Oracles: exact statevector values; statistical
comparisons over several fixed seeds with margins; the shots the ledger should hold.
"""

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.engines import SamplerEngine
from qdensity.execution.mitigated import mitigated_expectation
from qdensity.hardware.mitigation import ReadoutMitigator, hamming_weights
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
    for seed in (1, 2):
        eng = SamplerEngine(target=tgt, seed=seed)
        mit = ReadoutMitigator(tgt, shots=6000, seed=50 + seed, ledger=eng.ledger)
        raw = mitigated_expectation(qc, obs, [], engine=eng, shots=6000, postselect=None)
        fixed = mitigated_expectation(qc, obs, [], engine=eng, shots=6000, mitigator=mit,
                                      postselect=None)
        assert abs(fixed.value[0] - 0.0) <= 5 * fixed.standard_error[0] + 0.01
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
    for seed in (0, 1, 2):
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
    eng = SamplerEngine(target=tgt, seed=7)
    mit = ReadoutMitigator(tgt, seed=8, ledger=eng.ledger)
    alpha = model.alpha(x)[0]
    parts = [mitigated_expectation(model.circuit(k), model.observable, model.rows(k, x),
                                   engine=eng, shots=4000, mitigator=mit)
             for k in range(model.num_subunitaries)]
    value = sum(a * p.value[0] for a, p in zip(alpha, parts, strict=True))
    se = np.sqrt(sum((a * p.standard_error[0]) ** 2 for a, p in zip(alpha, parts, strict=True)))
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
