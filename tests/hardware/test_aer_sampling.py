"""The default Aer sampler of a target: method per PUB, reproducible, statistically unchanged."""

import numpy as np
import pytest
import qiskit_aer  # noqa: F401  (registers save_probabilities)
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter
from qiskit_aer import AerSimulator
from scipy import stats

from qdensity.hardware import aer_sampling
from qdensity.hardware.aer_samplers import AdaptiveSampler
from qdensity.hardware.aer_sampling import (
    DENSITY_MATRIX_MAX_QUBITS,
    FAST_SAMPLER_OPTIONS,
    active_qubits,
    aer_options,
)
from qdensity.hardware.targets import get_target


def _ghz_ry(n: int) -> QuantumCircuit:
    theta = Parameter("t")
    qc = QuantumCircuit(n)
    qc.ry(theta, 0)
    for q in range(n - 1):
        qc.cx(q, q + 1)
    qc.measure_all()
    return qc


def test_active_qubits_ignore_idle_wires_and_barriers():
    qc = QuantumCircuit(19, 2)
    qc.barrier()
    qc.h(4)
    qc.cx(4, 11)
    qc.measure([4, 11], [0, 1])
    assert active_qubits(qc) == 2
    with pytest.raises(TypeError, match="circuit"):
        active_qubits("qc")


def test_rule_is_the_documented_crossover():
    # noisy: density matrix from the measured crossover (8 up to 4 active qubits, 16, 32, 96,
    # 64 at 5 to 8, 2 ** (a - 2) above), up to DENSITY_MATRIX_MAX_QUBITS active qubits
    table = {5: 16, 6: 32, 7: 96, 8: 64}
    for a in range(1, DENSITY_MATRIX_MAX_QUBITS + 3):
        at = 8 if a <= 4 else table.get(a, 2 ** (a - 2))
        expect = "density_matrix" if a <= DENSITY_MATRIX_MAX_QUBITS else "statevector"
        assert aer_options(a, at, True)["method"] == expect
        if at > 1:
            assert aer_options(a, at - 1, True)["method"] == "statevector"
    for opts in (aer_options(6, 16, True), aer_options(10, 64, True), aer_options(6, 99, False),
                 FAST_SAMPLER_OPTIONS):
        # shot branching with noise samples wrong distributions in qiskit-aer 0.18.2
        assert opts["shot_branching_enable"] is False
        assert opts["runtime_parameter_bind_enable"] is True
    assert aer_options(6, 16, True)["max_parallel_threads"] == 1
    assert aer_options(20, 10, False)["max_parallel_threads"] == 0
    with pytest.raises(ValueError, match="shots"):
        aer_options(3, 0, True)
    with pytest.raises(ValueError, match="rows"):
        aer_options(3, 10, True, rows=0)


def _threads(opts: dict) -> str:
    assert opts["method"] == "statevector"
    if opts["max_parallel_threads"] == 1:
        assert "max_parallel_shots" not in opts
        return "one"
    assert opts["max_parallel_threads"] == 0 and opts["max_parallel_shots"] == 0
    return "all"


def test_trajectories_spread_over_threads_only_for_large_calls_on_an_idle_machine(monkeypatch):
    # the module's rule: from 8 active qubits and PARALLEL_TRAJECTORIES trajectories a call
    # (rows x shots), or from 14 active qubits, and only while a core is idle
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: True)
    big = aer_sampling.PARALLEL_TRAJECTORIES
    assert _threads(aer_options(8, 16, True, rows=16)) == "one"  # 256 trajectories
    assert _threads(aer_options(10, 16, True, rows=16)) == "one"
    assert _threads(aer_options(12, 256, True, rows=big // 256 - 1)) == "one"
    assert _threads(aer_options(12, 256, True, rows=big // 256)) == "all"
    assert _threads(aer_options(7, 4, True, rows=big)) == "one"  # below 8 active qubits
    assert _threads(aer_options(8, 4, True, rows=big // 4)) == "all"
    assert _threads(aer_options(14, 1, True)) == "all"
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: False)  # every core busy
    assert _threads(aer_options(12, 256, True, rows=big)) == "one"
    assert _threads(aer_options(14, 1, True)) == "one"
    monkeypatch.setattr(aer_sampling, "LOAD_AWARE", False)
    assert _threads(aer_options(14, 1, True)) == "all"


def test_the_sampler_counts_a_pubs_rows(monkeypatch):
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: True)
    tgt = get_target("heavy_hex", 8, seed=1)
    tqc = tgt.transpile(_ghz_ry(8))
    sampler = tgt.sampler(seed=3)
    assert sampler.choose(tqc, 16, rows=1)["max_parallel_threads"] == 1
    assert sampler.choose(tqc, 16, rows=200)["max_parallel_threads"] == 0
    seen = []
    real = AdaptiveSampler.choose
    monkeypatch.setattr(AdaptiveSampler, "choose",
                        lambda self, c, s, rows=1: seen.append(rows) or real(self, c, s, rows))
    vals = np.linspace(0, 1, 6).reshape(3, 2, 1)  # a (3, 2) array of rows: 6 rows
    sampler.run([(tqc, vals, 4), (tqc, [0.5], 4)]).result()
    assert seen == [6, 1]


@pytest.mark.parametrize(("active", "shots", "method"), [
    # the benchmark grid's cells: at 4 active qubits a density-matrix row (~1 ms) costs a few
    # trajectories (~0.17 ms each), at 6 and 8 qubits 35-60 of them
    (4, 7, "statevector"), (4, 16, "density_matrix"), (4, 256, "density_matrix"),
    (6, 16, "statevector"), (6, 32, "density_matrix"),
    (8, 16, "statevector"), (8, 63, "statevector"), (8, 64, "density_matrix"),
    (10, 255, "statevector"), (10, 256, "density_matrix"), (12, 256, "statevector"),
    (12, 4000, "density_matrix"), (13, 4000, "statevector")])
def test_rule_on_small_cells(active, shots, method):
    assert aer_options(active, shots, True)["method"] == method


def test_default_sampler_chooses_per_pub_and_accepts_overrides():
    tgt = get_target("heavy_hex", 5, seed=1)
    sampler = tgt.sampler(seed=3)
    assert isinstance(sampler, AdaptiveSampler)
    tqc = tgt.transpile(_ghz_ry(5))
    assert tqc.num_qubits == 19 and active_qubits(tqc) == 5
    assert sampler.choose(tqc, 1000)["method"] == "density_matrix"
    assert sampler.choose(tqc, 4)["method"] == "statevector"
    assert tgt.sampler(options={"method": "statevector"}).choose(tqc, 1000)["method"] == \
        "statevector"
    clean = get_target("heavy_hex", 5, seed=1, noise=False).sampler()
    assert clean.choose(tqc, 1000)["method"] == "automatic"
    with pytest.raises(TypeError, match="options"):
        tgt.sampler(options=["method"])


def _counts(sampler, pubs):
    return [r.data.meas.get_counts() for r in sampler.run(pubs).result()]


def test_same_seed_same_counts_across_mixed_methods():
    tgt = get_target("line", 4, seed=2)
    wide, narrow = tgt.transpile(_ghz_ry(4)), tgt.transpile(_ghz_ry(2))
    vals = np.array([[0.3], [1.9]])
    # one run call, two methods: 2 active qubits at 96 shots -> density matrix,
    # 4 active qubits at 3 shots -> trajectories
    pubs = [(wide, vals, 3), (narrow, vals, 96), (wide, vals, 3)]
    a = tgt.sampler(seed=11)
    assert a.choose(narrow, 96)["method"] == "density_matrix"
    assert a.choose(wide, 3)["method"] == "statevector"
    first = _counts(a, pubs)
    assert first == _counts(tgt.sampler(seed=11), pubs)
    assert first != _counts(tgt.sampler(seed=12), pubs)



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
    auto = tgt.sampler(seed=first)
    assert auto.choose(circuit, shots)["method"] == "density_matrix"
    p = _frequencies(auto, circuit, vals, shots)
    # the fixed-method sampler with its fast options (shot branching, once among them, gave a
    # row another row's counts in about one run in 75)
    q = _frequencies(tgt.sampler(seed=first + 1, method=forced), circuit, vals, shots)
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
    # 4 active qubits at 4 shots per row run as statevector trajectories (the density
    # matrix from 8): 640 rows of one parameter value, pooled, against the exact outcome
    # distribution (density matrix and readout confusion)
    tgt = get_target("heavy_hex", 4, seed=5)
    circuit = tgt.transpile(_ghz_ry(4))
    # Aer seeds shot k with seed + k: seeds 7919 apart keep the 2560 shots' streams apart
    sampler = tgt.sampler(seed=7919 * _stat_seed(0) + 31)
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
    sampler = tgt.sampler(seed=7919 * _stat_seed(0) + 57, method="matrix_product_state")
    observed = _frequencies(sampler, circuit, np.array([[0.9]]), 2560)[0] * 2560
    expected = _exact_outcomes(tgt, circuit, 0.9) * 2560
    rare = expected < 5
    f_obs = np.append(observed[~rare], observed[rare].sum())
    f_exp = np.append(expected[~rare], expected[rare].sum())
    # false failure 1e-4 (the chi-square approximation of the test)
    assert stats.chisquare(f_obs, f_exp).pvalue > 1e-4
