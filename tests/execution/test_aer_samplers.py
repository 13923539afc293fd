"""The default Aer sampler of a target (target_sampler, AdaptiveSampler): method per PUB,
reproducible, statistically unchanged."""

import numpy as np
import pytest
import qiskit_aer  # noqa: F401  (registers save_probabilities)
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter
from qiskit_aer import AerSimulator
from scipy import stats

from qdensity.execution.samplers import AdaptiveSampler, target_sampler
from qdensity.hardware import aer_sampling
from qdensity.hardware.aer_sampling import active_qubits
from qdensity.hardware.targets import get_target


def _ghz_ry(n: int) -> QuantumCircuit:
    theta = Parameter("t")
    qc = QuantumCircuit(n)
    qc.ry(theta, 0)
    for q in range(n - 1):
        qc.cx(q, q + 1)
    qc.measure_all()
    return qc


def test_the_sampler_counts_a_pubs_rows(monkeypatch):
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: True)
    tgt = get_target("heavy_hex", 8, seed=1)
    tqc = tgt.transpile(_ghz_ry(8))
    sampler = target_sampler(tgt, seed=3)
    assert sampler.choose(tqc, 16, rows=1)["max_parallel_threads"] == 1
    assert sampler.choose(tqc, 16, rows=200)["max_parallel_threads"] == 0
    seen = []
    real = AdaptiveSampler.choose
    monkeypatch.setattr(AdaptiveSampler, "choose",
                        lambda self, c, s, rows=1: seen.append(rows) or real(self, c, s, rows))
    vals = np.linspace(0, 1, 6).reshape(3, 2, 1)  # a (3, 2) array of rows: 6 rows
    sampler.run([(tqc, vals, 4), (tqc, [0.5], 4)]).result()
    assert seen == [6, 1]


def test_default_sampler_chooses_per_pub_and_accepts_overrides():
    tgt = get_target("heavy_hex", 5, seed=1)
    sampler = target_sampler(tgt, seed=3)
    assert isinstance(sampler, AdaptiveSampler)
    tqc = tgt.transpile(_ghz_ry(5))
    assert tqc.num_qubits == 19 and active_qubits(tqc) == 5
    assert sampler.choose(tqc, 1000)["method"] == "density_matrix"
    assert sampler.choose(tqc, 4)["method"] == "statevector"
    assert target_sampler(tgt, options={"method": "statevector"}).choose(tqc, 1000)["method"] == \
        "statevector"
    clean = target_sampler(get_target("heavy_hex", 5, seed=1, noise=False))
    assert clean.choose(tqc, 1000)["method"] == "automatic"
    with pytest.raises(TypeError, match="options"):
        target_sampler(tgt, options=["method"])


def _counts(sampler, pubs):
    return [r.data.meas.get_counts() for r in sampler.run(pubs).result()]


def test_same_seed_same_counts_across_mixed_methods():
    tgt = get_target("line", 4, seed=2)
    wide, narrow = tgt.transpile(_ghz_ry(4)), tgt.transpile(_ghz_ry(2))
    vals = np.array([[0.3], [1.9]])
    # one run call, two methods: 2 active qubits at 96 shots -> density matrix,
    # 4 active qubits at 3 shots -> trajectories
    pubs = [(wide, vals, 3), (narrow, vals, 96), (wide, vals, 3)]
    a = target_sampler(tgt, seed=11)
    assert a.choose(narrow, 96)["method"] == "density_matrix"
    assert a.choose(wide, 3)["method"] == "statevector"
    first = _counts(a, pubs)
    assert first == _counts(target_sampler(tgt, seed=11), pubs)
    assert first != _counts(target_sampler(tgt, seed=12), pubs)


def _frequencies(sampler, circuit, vals, shots):
    res = sampler.run([(circuit, vals, shots)]).result()[0].data.meas
    bits = res.array  # (rows, shots, bytes): 4 measured qubits fit one byte
    out = np.zeros((len(vals), 16))
    for r in range(len(vals)):
        out[r] = np.bincount(bits[r, :, -1].astype(int), minlength=16) / shots
    return out


@pytest.mark.parametrize("forced", ["statevector", "density_matrix"])
def test_estimates_agree_with_the_other_method_within_standard_errors(forced):
    # the default picks the density matrix at 2000 shots (4 active qubits); a fixed-method
    # sampler (plain trajectories, or Aer's density matrix)
    # samples the same noisy distribution: every outcome frequency within 5 standard errors
    tgt = get_target("heavy_hex", 4, seed=5)
    circuit = tgt.transpile(_ghz_ry(4))
    vals = np.array([[0.4], [2.2]])
    shots = 2000
    first = 2 * _stat_seed(0) + 7  # seeds 7, 8; QDENSITY_STAT_SEED=S: 2S + 7, 2S + 8
    auto = target_sampler(tgt, seed=first)
    assert auto.choose(circuit, shots)["method"] == "density_matrix"
    p = _frequencies(auto, circuit, vals, shots)
    # the fixed-method sampler with its fast options (shot branching, once among them, gave a
    # row another row's counts in about one run in 75)
    q = _frequencies(target_sampler(tgt, seed=first + 1, method=forced), circuit, vals, shots)
    # homogeneity of the two samples' counts, row by row (chi-square on the 2 x outcomes
    # table; a per-outcome normal bound fails for outcomes seen a handful of times)
    for row_p, row_q in zip(p, q, strict=True):
        table = np.rint(np.array([row_p, row_q]) * shots)
        table = table[:, table.sum(axis=0) > 0]
        # two rows at 1e-5: false failure 2e-5 (the chi-square approximation of the test)
        assert stats.chi2_contingency(table).pvalue > 1e-5
    # and noise is there: the GHZ-like state leaks outside {0000, 1111}
    assert p[:, [i for i in range(16) if i not in (0, 15)]].sum() > 0.02


def _exact_outcomes(tgt, circuit, value: float) -> np.ndarray:
    """Outcome distribution of ``circuit`` (clbit k is bit k) on ``tgt``'s noise: Aer's density
    matrix with the device's whole noise model, then each measured qubit's readout confusion
    matrix from that model."""
    bound = circuit.assign_parameters([value])
    where = {bound.find_bit(i.clbits[0]).index: bound.find_bit(i.qubits[0]).index
             for i in bound.data if i.operation.name == "measure"}
    qubits = [where[k] for k in range(len(where))]
    free = bound.remove_final_measurements(inplace=False)
    free.save_probabilities(qubits)
    dm = AerSimulator.from_backend(tgt.backend, method="density_matrix",
                                   noise_model=tgt.noise_model)
    p = np.asarray(dm.run(free).result().data()["probabilities"]).reshape([2] * len(qubits))
    readout = {tuple(e["gate_qubits"][0]): np.asarray(e["probabilities"])
               for e in tgt.noise_model.to_dict()["errors"] if e["type"] == "roerror"}
    for k, q in enumerate(qubits):  # bit k is axis len - 1 - k; confusion[true, read]
        axis = len(qubits) - 1 - k
        p = np.moveaxis(np.tensordot(readout[(q,)], np.moveaxis(p, axis, 0), axes=(0, 0)), 0,
                        axis)
    return p.reshape(-1)


def test_trajectories_at_few_shots_match_the_exact_noisy_distribution():
    # 4 active qubits at 4 shots per row: Aer's choice is statevector trajectories (the
    # density matrix from 8), but the default sampler draws such a PUB from the exact noisy
    # distribution (noisy_exact, from 2 shots at 4 qubits); a method override keeps it with
    # Aer, so the trajectories are what is tested. 640 rows of one parameter value, pooled,
    # against the exact outcome distribution (density matrix and readout confusion)
    tgt = get_target("heavy_hex", 4, seed=5)
    circuit = tgt.transpile(_ghz_ry(4))
    # Aer seeds shot k with seed + k: seeds 7919 apart keep the 2560 shots' streams apart
    sampler = target_sampler(tgt, seed=7919 * _stat_seed(0) + 31,
                             options={"method": "statevector"})
    assert target_sampler(tgt).choose(circuit, 4)["method"] == "statevector"
    assert sampler.choose(circuit, 4)["method"] == "statevector"
    vals = np.full((640, 1), 0.9)
    observed = _frequencies(sampler, circuit, vals, 4).sum(axis=0) * 4
    expected = _exact_outcomes(tgt, circuit, 0.9) * 640 * 4
    assert abs(expected.sum() - 2560) < 1e-6 and expected[[i not in (0, 15) for i in
                                                            range(16)]].sum() > 20  # noisy
    rare = expected < 5  # pooled into one cell for the chi-square approximation
    f_obs = np.append(observed[~rare], observed[rare].sum())
    f_exp = np.append(expected[~rare], expected[rare].sum())
    # goodness of fit; false failure 1e-4 (the chi-square approximation of the test)
    assert stats.chisquare(f_obs, f_exp).pvalue > 1e-4


def test_noisy_mps_on_its_relabelled_line_matches_the_exact_distribution():
    # matrix-product-state trajectories put the active qubits on Aer's line by reverse
    # Cuthill-McKee and renumber the noise with them: outcome counts against the exact noisy
    # distribution of the device's whole model, chi-square at 1e-4
    tgt = get_target("fake_kolkata", seed=1)
    circuit = tgt.transpile(_ghz_ry(4))
    sampler = target_sampler(tgt, seed=7919 * _stat_seed(0) + 57, method="matrix_product_state")
    observed = _frequencies(sampler, circuit, np.array([[0.9]]), 2560)[0] * 2560
    expected = _exact_outcomes(tgt, circuit, 0.9) * 2560
    rare = expected < 5
    f_obs = np.append(observed[~rare], observed[rare].sum())
    f_exp = np.append(expected[~rare], expected[rare].sum())
    # false failure 1e-4 (the chi-square approximation of the test)
    assert stats.chisquare(f_obs, f_exp).pvalue > 1e-4
