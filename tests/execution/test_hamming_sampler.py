"""HammingWeightSampler: exact probabilities in the weight-k subspace, shots, readout, shapes.

Oracles: qiskit ``Statevector`` probabilities (exactly, and by chi-square on the counts),
qiskit-aer's ``SamplerV2`` with a readout-only noise model (two-sample chi-square, and the
readout confusion applied to the ``Statevector`` probabilities), Aer's result shapes.

Statistical tests: each chi-square test fails with probability ``ALPHA = 1e-4`` when the
sampler is right (bins with expected count below 5 are pooled); with the fixed seeds here
the outcome is deterministic, and the ~40 such tests together have a false-failure rate below
``4e-3`` for any other seed.
"""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import ClassicalRegister, QuantumCircuit, QuantumRegister, transpile
from qiskit.circuit import ParameterVector
from qiskit.circuit.library import HGate, RYGate, XXPlusYYGate
from qiskit.quantum_info import Statevector
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, ReadoutError, depolarizing_error
from qiskit_aer.primitives import SamplerV2
from scipy import stats

from qdensity import HammingWeightSampler
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.execution.sampler.engine import bitarray_to_bits
from qdensity.execution.samplers._hamming_compile import compile_template
from qdensity.execution.samplers.hamming import _Compiled

ALPHA = 1e-4


def random_circuit(n: int, k: int, seed: int, *, parameterised: bool, gates: int = 14,
                   unary_only: bool = False) -> QuantumCircuit:
    """X gates on k random qubits, then random weight-preserving gates (all families)."""
    rng = np.random.default_rng(seed)
    qc = QuantumCircuit(n)
    for q in rng.choice(n, k, replace=False):
        qc.x(int(q))
    theta = ParameterVector("t", gates)
    for g in range(gates):
        i, j = sorted(int(v) for v in rng.choice(n, 2, replace=False))
        a = theta[g] if parameterised else float(rng.uniform(-np.pi, np.pi))
        kind = g % 2 if unary_only else g % 7
        if kind == 0:
            qc.append(RBSGate(a), [i, j])
        elif kind == 1:
            qc.append(FBSGate(a, j - i + 1), list(range(i, j + 1)))
        elif kind == 2:
            qc.append(XXPlusYYGate(a, 0.37), [i, j])
        elif kind == 3:
            qc.rz(a, i)
            qc.cz(i, j)
        elif kind == 4:
            qc.cp(a, i, j)
            qc.swap(i, j)
        elif kind == 5:
            qc.p(a, j)
            qc.iswap(i, j)
            qc.rzz(a, i, j)
        else:
            qc.crz(a, i, j)
            qc.s(i)
            qc.t(j)
    return qc


def _measured(qc: QuantumCircuit) -> QuantumCircuit:
    out = qc.copy()
    out.measure_all()
    return out


def _statevector_probs(qc: QuantumCircuit, values) -> np.ndarray:
    bound = qc.assign_parameters(values) if qc.num_parameters else qc
    return Statevector(bound.remove_final_measurements(inplace=False)).probabilities()


def _codes(bits: np.ndarray) -> np.ndarray:
    """(shots, m) bool -> integer outcome (clbit j = bit j)."""
    return (bits.astype(np.int64) << np.arange(bits.shape[-1])).sum(axis=-1)


def _chi2_pvalue(counts: np.ndarray, probs: np.ndarray) -> float:
    """Goodness of fit, bins with expected count < 5 pooled into one."""
    shots = counts.sum()
    expected = probs * shots
    big = expected >= 5
    obs = np.append(counts[big], counts[~big].sum())
    exp = np.append(expected[big], expected[~big].sum())
    if exp[-1] < 5:  # pool the remainder into the smallest big bin
        obs, exp = obs[:-1], exp[:-1]
        small = np.argmin(exp)
        obs[small] += counts[~big].sum()
        exp[small] += expected[~big].sum()
    assert obs.sum() == shots
    if obs.size < 2:
        return 1.0
    return float(stats.chisquare(obs, exp * shots / exp.sum()).pvalue)


def _two_sample_pvalue(a: np.ndarray, b: np.ndarray) -> float:
    keep = (a + b) > 0
    table = np.vstack([a[keep], b[keep]])
    if table.shape[1] < 2:
        return 1.0
    return float(stats.chi2_contingency(table, correction=False).pvalue)


# -- exact probabilities -------------------------------------------------------------------


@pytest.mark.parametrize("n,k", [(4, 1), (6, 1), (5, 2), (7, 2), (6, 3), (8, 0)])
@pytest.mark.parametrize("parameterised", [False, True])
def test_probabilities_equal_statevector(n, k, parameterised):
    qc = random_circuit(n, k, seed=10 * n + k, parameterised=parameterised)
    rng = np.random.default_rng(3)
    rows = rng.uniform(-np.pi, np.pi, (3, qc.num_parameters))
    comp = _Compiled(compile_template(qc))
    probs = comp.probabilities(rows)
    index = [sum(1 << int(q) for q in s) for s in comp.outcome_qubits()]
    for r in range(3):
        exact = _statevector_probs(qc, rows[r])
        np.testing.assert_allclose(probs[r], exact[index], atol=1e-12)
        assert exact[index].sum() == pytest.approx(1.0, abs=1e-12)


def test_unary_rbs_fbs_bodies_run_on_the_unary_engine():
    qc = random_circuit(7, 1, seed=4, parameterised=True, unary_only=True)
    comp = _Compiled(compile_template(qc))
    assert comp.unary is not None
    rows = np.random.default_rng(0).uniform(-3, 3, (4, qc.num_parameters))
    probs = comp.probabilities(rows)
    for r in range(4):
        exact = _statevector_probs(qc, rows[r])
        np.testing.assert_allclose(probs[r], exact[[1 << j for j in range(7)]], atol=1e-12)
    result = HammingWeightSampler(seed=0).run([(_measured(qc), rows[0], 10)]).result()
    assert result[0].metadata["simulator_metadata"]["engine"] == "unary"


def test_composite_loader_followed_through_its_definition():
    from qdensity.circuits.loaders import unary_loader

    qc = unary_loader(np.array([0.3, -0.5, 0.1, 0.8, 0.0, 0.2]))
    comp = _Compiled(compile_template(qc))
    assert comp.template.weight == 1
    exact = _statevector_probs(qc, [])
    np.testing.assert_allclose(comp.probabilities(np.zeros((1, 0)))[0],
                               exact[[1 << j for j in range(6)]], atol=1e-12)


# -- counts by chi-square -------------------------------------------------------------------


@pytest.mark.parametrize("n,k", [(5, 1), (10, 1), (6, 2), (9, 2)])
@pytest.mark.parametrize("parameterised", [False, True])
def test_counts_chi_square_against_statevector(n, k, parameterised):
    qc = _measured(random_circuit(n, k, seed=n * 7 + k, parameterised=parameterised))
    rows = np.random.default_rng(n).uniform(-np.pi, np.pi, (2, qc.num_parameters))
    shots = 4000
    pub = (qc, rows, shots) if parameterised else (qc, None, shots)
    data = HammingWeightSampler(seed=11).run([pub]).result()[0].data.meas
    nrows = 2 if parameterised else 1
    bits = bitarray_to_bits(data, nrows, shots)
    for r in range(nrows):
        exact = _statevector_probs(qc, rows[r] if parameterised else [])
        counts = np.bincount(_codes(bits[r]), minlength=2**n)
        assert np.all(counts[exact < 1e-14] == 0)  # never outside the subspace
        assert _chi2_pvalue(counts, exact) > ALPHA


# -- readout channel ------------------------------------------------------------------------


def _readout_model(n: int, seed: int) -> tuple[NoiseModel, np.ndarray]:
    rng = np.random.default_rng(seed)
    pairs = rng.uniform(0.01, 0.15, (n, 2))
    model = NoiseModel()
    for q, (p01, p10) in enumerate(pairs):
        model.add_readout_error(ReadoutError([[1 - p01, p01], [p10, 1 - p10]]), [q])
    return model, pairs


def _confused(probs: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Apply independent per-qubit confusion matrices to a 2**n distribution (oracle)."""
    n = pairs.shape[0]
    t = probs.reshape([2] * n)  # axis a is qubit n - 1 - a
    for q, (p01, p10) in enumerate(pairs):
        conf = np.array([[1 - p01, p10], [p01, 1 - p10]])  # conf[observed, true]
        t = np.moveaxis(np.tensordot(conf, t, axes=([1], [n - 1 - q])), 0, n - 1 - q)
    return t.reshape(-1)


@pytest.mark.parametrize("n,k", [(5, 1), (6, 2)])
def test_readout_channel_against_aer_and_confusion_oracle(n, k):
    qc = _measured(random_circuit(n, k, seed=99 + n, parameterised=True))
    values = np.random.default_rng(1).uniform(-3, 3, qc.num_parameters)
    model, pairs = _readout_model(n, seed=n)
    shots = 6000
    ours = HammingWeightSampler(seed=5, readout_error=model).run([(qc, values, shots)])
    ours_bits = bitarray_to_bits(ours.result()[0].data.meas, 1, shots)[0]
    sim = AerSimulator(noise_model=model)
    aer = SamplerV2.from_backend(sim, seed=6).run(
        [(transpile(qc, sim, optimization_level=0), values, shots)]).result()
    aer_bits = bitarray_to_bits(aer[0].data.meas, 1, shots)[0]
    a = np.bincount(_codes(ours_bits), minlength=2**n)
    b = np.bincount(_codes(aer_bits), minlength=2**n)
    assert _two_sample_pvalue(a, b) > ALPHA
    oracle = _confused(_statevector_probs(qc, values), pairs)
    assert _chi2_pvalue(a, oracle) > ALPHA
    assert np.count_nonzero(a) > n  # readout errors leave the subspace


def test_readout_from_per_qubit_pairs_and_float():
    qc = QuantumCircuit(3)
    qc.x(0)
    qc.measure_all()
    shots = 20000
    pairs = np.array([[0.0, 0.2], [0.1, 0.0], [0.05, 0.0]])
    bits = bitarray_to_bits(HammingWeightSampler(seed=2, readout_error=pairs).run(
        [qc], shots=shots).result()[0].data.meas, 1, shots)[0]
    # qubit 0 is 1 (flips to 0 w.p. 0.2), qubits 1, 2 are 0 (flip to 1 w.p. 0.1, 0.05)
    for q, p in [(0, 0.8), (1, 0.1), (2, 0.05)]:
        ones = int(bits[:, q].sum())
        assert stats.binomtest(ones, shots, p).pvalue > ALPHA
    bits = bitarray_to_bits(HammingWeightSampler(seed=2, readout_error=0.25).run(
        [qc], shots=shots).result()[0].data.meas, 1, shots)[0]
    for q, p in [(0, 0.75), (1, 0.25), (2, 0.25)]:
        assert stats.binomtest(int(bits[:, q].sum()), shots, p).pvalue > ALPHA


def test_readout_from_target_calibration():
    from qiskit.circuit import Measure
    from qiskit.transpiler import InstructionProperties, Target

    target = Target(num_qubits=2)
    target.add_instruction(Measure(), {(0,): InstructionProperties(error=0.3),
                                       (1,): InstructionProperties(error=0.0)})
    qc = QuantumCircuit(2)
    qc.x(1)
    qc.measure_all()
    shots = 20000
    bits = bitarray_to_bits(HammingWeightSampler(seed=4, readout_error=target).run(
        [qc], shots=shots).result()[0].data.meas, 1, shots)[0]
    assert stats.binomtest(int(bits[:, 0].sum()), shots, 0.3).pvalue > ALPHA
    assert bits[:, 1].all()


# -- seeds and shapes -----------------------------------------------------------------------


def test_seeded_runs_are_bit_identical_and_seeds_differ():
    qc = _measured(random_circuit(6, 2, seed=1, parameterised=True))
    rows = np.random.default_rng(0).uniform(-3, 3, (4, qc.num_parameters))

    def run(seed):
        res = HammingWeightSampler(seed=seed, readout_error=0.05).run(
            [(qc, rows, 300), (qc, rows[0], 200)]).result()
        return [r.data.meas.array.copy() for r in res]

    first, again, other = run(7), run(7), run(8)
    for x, y in zip(first, again, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(first[0], other[0])
    gen_a = run(np.random.default_rng(3))
    gen_b = run(np.random.default_rng(3))
    np.testing.assert_array_equal(gen_a[0], gen_b[0])


def _registers_circuit() -> QuantumCircuit:
    q = QuantumRegister(4, "q")
    a, b = ClassicalRegister(3, "alpha"), ClassicalRegister(2, "beta")
    qc = QuantumCircuit(q, a, b)
    p = ParameterVector("p", 2)
    qc.x(1)
    qc.append(RBSGate(p[0]), [1, 2])
    qc.append(RBSGate(p[1]), [0, 3])
    qc.measure([0, 1, 2], [0, 1, 2])
    qc.measure([3, 2], [3, 4])
    return qc


@pytest.mark.parametrize("shape", [(), (2, 3), (5,)])
def test_result_shapes_match_aer(shape):
    qc = _registers_circuit()
    values = np.random.default_rng(0).uniform(size=shape + (2,))
    aer_qc = transpile(qc, AerSimulator(), optimization_level=0)
    aer = SamplerV2(seed=1).run([(aer_qc, values, 37)]).result()
    ours = HammingWeightSampler(seed=1).run([(qc, values, 37)]).result()
    assert ours.metadata == aer.metadata
    x, y = aer[0], ours[0]
    assert y.data.shape == x.data.shape == shape
    assert list(y.data.keys()) == list(x.data.keys())
    for key in x.data.keys():
        bx, by = x.data[key], y.data[key]
        assert (by.shape, by.num_shots, by.num_bits, by.array.shape, by.array.dtype) == (
            bx.shape, bx.num_shots, bx.num_bits, bx.array.shape, bx.array.dtype)
    assert set(y.metadata) == set(x.metadata)
    assert y.metadata["shots"] == 37
    assert y.join_data().num_bits == x.join_data().num_bits == 5


def test_parameter_free_pub_and_default_shots():
    qc = QuantumCircuit(3)
    qc.x(2)
    qc.measure_all()
    res = HammingWeightSampler(default_shots=9, seed=0).run([qc]).result()
    assert res[0].data.meas.num_shots == 9
    assert res[0].data.meas.get_counts() == {"100": 9}


# -- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize("gate,name", [(HGate(), "h"), (RYGate(0.3), "ry")])
def test_gate_that_changes_weight_is_refused_by_name(gate, name):
    qc = QuantumCircuit(3)
    qc.x(0)
    qc.append(RBSGate(0.2), [0, 1])
    qc.append(gate, [2])
    qc.measure_all()
    with pytest.raises(ValueError, match=rf"instruction 2 '{name}'.*qiskit-aer"):
        HammingWeightSampler().run([qc])


def test_gate_after_a_final_flip_and_mid_circuit_measurement_refused():
    qc = QuantumCircuit(2)
    qc.x(0)
    qc.append(RBSGate(0.2), [0, 1])
    qc.x(1)  # a relabelling only if nothing but a measurement follows on qubit 1
    qc.append(RBSGate(0.3), [0, 1])
    qc.measure_all()
    with pytest.raises(ValueError, match="instruction 3 'rbs'.*after the bit flip of "
                                         "instruction 2"):
        HammingWeightSampler().run([qc])
    qc = QuantumCircuit(2, 2)
    qc.x(0)
    qc.measure(0, 0)
    qc.append(RBSGate(0.2), [0, 1])
    with pytest.raises(ValueError, match="'rbs'.*after a measurement"):
        HammingWeightSampler().run([qc])


def test_gate_noise_refused_by_name():
    model = NoiseModel()
    model.add_all_qubit_quantum_error(depolarizing_error(0.01, 2), ["cz"])
    with pytest.raises(ValueError, match="gate noise on 'cz'.*qiskit-aer"):
        HammingWeightSampler(readout_error=model)


@pytest.mark.parametrize("shots", [0, -3])
def test_shots_not_positive_refused(shots):
    qc = QuantumCircuit(2)
    qc.measure_all()
    with pytest.raises(ValueError, match="shots"):
        HammingWeightSampler().run([qc], shots=shots)
    with pytest.raises(ValueError, match="shots of pub 0"):
        HammingWeightSampler().run([(qc, None, shots)])


@pytest.mark.parametrize("shots", [1.5, True, "10"])
def test_shots_not_int_refused(shots):
    qc = QuantumCircuit(2)
    qc.measure_all()
    with pytest.raises(TypeError, match="shots"):
        HammingWeightSampler().run([qc], shots=shots)


def test_parameter_array_of_wrong_shape_names_the_pub():
    qc = _registers_circuit()
    good = (qc, np.zeros(2), 5)
    with pytest.raises(ValueError, match="pub 1"):
        HammingWeightSampler().run([good, (qc, np.zeros((3, 4)), 5)])
    with pytest.raises(ValueError, match="pub 0"):
        HammingWeightSampler().run([(qc, None, 5)])


def test_subspace_too_large_refused_before_allocation():
    qc = QuantumCircuit(64)
    for q in range(32):
        qc.x(q)
    qc.append(RBSGate(0.1), [31, 32])
    qc.measure_all()
    with pytest.raises(ValueError, match=r"C\(64, 32\).*max_dimension"):
        HammingWeightSampler().run([qc])
    small = HammingWeightSampler(max_dimension=10)
    with pytest.raises(ValueError, match=r"C\(6, 2\) = 15"):
        small.run([_measured(random_circuit(6, 2, seed=0, parameterised=False))])


@pytest.mark.parametrize("bad,err", [(1.5, ValueError), (-0.1, ValueError),
                                     ([[0.1, 0.2, 0.3]], ValueError), ("x", TypeError),
                                     (True, TypeError), ([[0.1, 2.0]], ValueError)])
def test_bad_readout_error_refused(bad, err):
    with pytest.raises(err, match="readout_error"):
        HammingWeightSampler(readout_error=bad)


def test_per_qubit_readout_shorter_than_circuit_refused():
    qc = QuantumCircuit(3)
    qc.measure_all()
    with pytest.raises(ValueError, match="measures qubit 2"):
        HammingWeightSampler(readout_error=[[0.1, 0.1], [0.1, 0.1]]).run([qc])


@pytest.mark.parametrize("seed", [-1, 1.5, "a"])
def test_bad_seed_refused(seed):
    with pytest.raises((TypeError, ValueError), match="seed"):
        HammingWeightSampler(seed=seed)


# -- SamplerEngine picks it wherever it is exact ----------------------------------------------


def _classifier(n: int, rows: int, shots: int):
    from qdensity import DensityQNN, Encoding, by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.gradients import density_gradient_plan

    subs = by_moments(round_robin(n)).sub_unitaries
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    X = np.random.default_rng(1).normal(size=(rows, n))
    return model, X, density_gradient_plan(model, X, method="commuting", shots=shots)


def _readout_target(n: int, p: float):
    from qiskit.transpiler import Target

    from qdensity import get_target

    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - p, p], [p, 1 - p]]))
    device = Target.from_configuration(["cz", "rz", "sx", "x", "measure"], num_qubits=n)
    return get_target(device, seed=0, noise_model=noise)


@pytest.mark.parametrize("readout", [0.0, 0.04])
def test_engine_answers_equal_in_law_whichever_sampler(readout):
    from qdensity import SamplerEngine

    n, rows, shots = 5, 3, 3000
    model, X, plan = _classifier(n, rows, shots)
    target = _readout_target(n, readout) if readout else None
    out = {}
    for choice in ("auto", "never"):
        engine = SamplerEngine(target=target, seed=3, progress=False, hamming_weight=choice)
        out[choice] = (plan.run(engine), engine.ledger)
    (ga, la), (gb, lb) = out["auto"], out["never"]
    assert {e.sampler for e in la.entries} == {"hamming_weight"}
    assert {e.sampler for e in lb.entries} == {"AdaptiveSampler"}
    assert [(e.label, e.circuits, e.shots) for e in la.entries] == [
        (e.label, e.circuits, e.shots) for e in lb.entries]
    # two independent estimates of the same outcome probabilities: z-test, Bonferroni over cells
    a, b = ga.outputs, gb.outputs
    pooled = (a + b) / 2
    se = np.sqrt(np.maximum(pooled * (1 - pooled), 1.0 / shots) * 2 / shots)
    bound = stats.norm.isf(ALPHA / (2 * a.size))
    assert np.max(np.abs(a - b) / se) < bound
    # and each against the exact law (outcome e_j read as itself or from e_i, two flips)
    exact = model.expert_outputs(X, method="unary")
    exact = (1 - readout) ** n * exact + readout**2 * (1 - readout) ** (n - 2) * (1 - exact)
    se = np.sqrt(np.maximum(exact * (1 - exact), 1.0 / shots) / shots)
    assert np.max(np.abs(a - exact) / se) < bound
    # the sampled Jacobians agree within their own standard errors
    for ja, jb, ea, eb in zip(ga.jacobians, gb.jacobians, ga.jacobian_errors,
                              gb.jacobian_errors, strict=True):
        scale = np.sqrt(ea**2 + eb**2) + 1e-12
        cells = sum(j.size for j in ga.jacobians)
        assert np.max(np.abs(ja - jb) / scale) < stats.norm.isf(ALPHA / (2 * cells))


def test_engine_sends_other_templates_to_aer_and_always_refuses_them():
    from qdensity import SamplerEngine
    from qdensity.execution.plans import CircuitJob

    qc = QuantumCircuit(3)
    qc.x(0)
    qc.append(RBSGate(0.3), [0, 1])
    qc.h(2)
    qc.measure_all()
    ok = QuantumCircuit(3)
    ok.x(0)
    ok.append(RBSGate(0.3), [0, 2])
    ok.measure_all()
    jobs = [CircuitJob(qc, np.zeros((2, 0)), 50, "mixed"), CircuitJob(ok, np.zeros((2, 0)), 50,
                                                                     "kept")]
    engine = SamplerEngine(seed=0, progress=False)
    results = engine.run(jobs)
    assert [e.sampler for e in engine.ledger.entries] == ["AdaptiveSampler", "hamming_weight"]
    assert [r.bits.shape for r in results] == [(2, 50, 3), (2, 50, 3)]
    assert engine.transpile_count == 1  # the Hamming-weight job is not transpiled
    always = SamplerEngine(seed=0, progress=False, hamming_weight="always")
    with pytest.raises(ValueError, match="'h'"):
        always.run(jobs)
    assert always.ledger.entries == []


def test_engine_gate_noise_goes_to_aer_or_is_refused():
    from qdensity import SamplerEngine, get_target

    target = get_target("line", 3, seed=1)
    ok = QuantumCircuit(3)
    ok.x(0)
    ok.append(RBSGate(0.3), [0, 2])
    ok.measure_all()
    from qdensity.execution.plans import CircuitJob

    engine = SamplerEngine(target=target, seed=0, progress=False)
    engine.run([CircuitJob(ok, np.zeros((1, 0)), 20, "noisy")])
    assert engine.ledger.entries[0].sampler == "AdaptiveSampler"
    always = SamplerEngine(target=target, seed=0, progress=False, hamming_weight="always")
    with pytest.raises(ValueError, match="gate noise"):
        always.run([CircuitJob(ok, np.zeros((1, 0)), 20, "noisy")])


def test_engine_seeded_runs_repeat():
    from qdensity import SamplerEngine

    _, _, plan = _classifier(4, 2, 100)

    def two_runs():
        engine = SamplerEngine(seed=9, progress=False)
        return [[r.bits.copy() for r in engine.run(plan.jobs)] for _ in range(2)]

    first, again = two_runs(), two_runs()
    for run_a, run_b in zip(first, again, strict=True):  # the same sequence of runs repeats
        for x, y in zip(run_a, run_b, strict=True):
            np.testing.assert_array_equal(x, y)
    # successive runs of one engine draw fresh shots
    assert any(not np.array_equal(x, y) for x, y in zip(first[0], first[1], strict=True))


@pytest.mark.parametrize("bad", ["yes", None, 1])
def test_engine_bad_hamming_weight_option(bad):
    from qdensity import SamplerEngine

    # a wrong value is a ValueError, a wrong type a TypeError (the declared contract)
    with pytest.raises((ValueError, TypeError), match="hamming_weight"):
        SamplerEngine(hamming_weight=bad)


def test_engine_always_with_mitigation_refused():
    from qdensity import SamplerEngine

    with pytest.raises(ValueError, match="hamming_weight='always'.*mitigation"):
        SamplerEngine(hamming_weight="always", mitigation="m3")


def test_density_qnn_sample_uses_the_hamming_sampler():
    from qiskit.quantum_info import SparsePauliOp

    from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
    from qdensity.circuits.ansatze import round_robin

    n = 4
    subs = by_moments(round_robin(n)).sub_unitaries
    model = DensityQNN(subs, encoding=Encoding.unary(n),
                       observable=SparsePauliOp("ZIII"), seed=0)
    x = np.random.default_rng(2).normal(size=(1, n))
    engine = SamplerEngine(seed=1, progress=False)
    est = model.sample(x, 4000, engine=engine, seed=1)
    assert {e.sampler for e in engine.ledger.entries} == {"hamming_weight"}
    exact = float(np.ravel(model.predict(x, method="statevector"))[0])
    # |Z| <= 1, so the estimate's standard deviation is at most 1 / sqrt(4000); 4.5 sd: 7e-6
    assert abs(float(np.ravel(est.estimate)[0]) - exact) < 4.5 / np.sqrt(4000)


def test_engine_results_keep_shots_packed_and_unpack_the_same_bits():
    import pickle

    from qdensity import SamplerEngine
    from qdensity.execution.sampler._packed_result import PackedJobResult

    qc = _measured(random_circuit(10, 1, seed=3, parameterised=True, unary_only=True))
    from qdensity.execution.plans import CircuitJob

    values = np.random.default_rng(0).uniform(-3, 3, (3, qc.num_parameters))
    job = CircuitJob(qc, values, 64, "packed")
    (res,) = SamplerEngine(seed=2, progress=False).run([job])
    assert isinstance(res, PackedJobResult)
    direct = HammingWeightSampler(seed=0).compile(qc)
    assert direct.weight == 1
    bits = res.bits
    assert bits.shape == (3, 64, 10) and bits.dtype == bool
    assert res.bits is bits  # unpacked once while held
    np.testing.assert_array_equal(bits.sum(axis=-1), 1)  # weight 1 on every shot
    again = pickle.loads(pickle.dumps(res))
    np.testing.assert_array_equal(again.bits, bits)
    freq = res.probabilities
    assert freq.shape == (3, 2**10)
    np.testing.assert_allclose(freq.sum(axis=1), 1.0)
