"""Oracle tests for plans (``qdensity.execution.plans``) and engines
(``qdensity.execution.engines``).

Oracles: ``Statevector.expectation_value`` / ``Statevector.probabilities`` of the unmeasured
circuit, brute-force parities and eigenvalues over all outcomes, ``Operator`` conjugation of
Pauli matrices, the analytic depolarised expectation ``(1 - p)^m cos(angle)`` and, for sampled
estimates, bounds of a few standard errors at fixed seeds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit.circuit import Parameter, ParameterVector, QuantumCircuit
from qiskit.quantum_info import Operator, Pauli, PauliList, SparsePauliOp, Statevector
from scipy.stats import binom

from qdensity.circuits.ansatze import hardware_efficient
from qdensity.circuits.gates import RBSGate
from qdensity.execution.exact import ExactEngine
from qdensity.execution.observables import basis_rotation, diagonal_values, z_parities
from qdensity.execution.plans import (
    CircuitJob,
    Plan,
    expectation_plan,
    measured,
    probabilities_plan,
)
from qdensity.execution.sampler.engine import SamplerEngine


def random_circuit(n: int, seed: int) -> QuantumCircuit:
    """Parameterised circuit with rx/ry/rz rotations, CNOTs and RBS gates (complex amplitudes)."""
    rng = np.random.default_rng(seed)
    theta = ParameterVector("θ", 3 * n)
    qc = QuantumCircuit(n)
    for q in range(n):
        qc.rx(theta[q], q)
        qc.rz(theta[n + q], q)
    for q in range(n - 1):
        qc.cx(q, q + 1)
    for q in range(n):
        qc.ry(theta[2 * n + q], q)
    qc.append(RBSGate(float(rng.uniform(-2, 2))), [0, n - 1])
    qc.s(n - 1)
    return qc


def random_observable(n: int, terms: int, seed: int) -> SparsePauliOp:
    rng = np.random.default_rng(seed)
    labels = ["".join(rng.choice(list("IXYZ"), n)) for _ in range(terms)] + ["I" * n]
    return SparsePauliOp(labels, rng.normal(size=terms + 1))


def exact_expectations(circuit, observable, rows) -> np.ndarray:
    return np.array([
        Statevector(circuit.assign_parameters(r)).expectation_value(observable).real for r in rows
    ])


# ------------------------------------------------------------------------------ exact engine


EXACT = ExactEngine()


@settings(max_examples=8, deadline=None)
@given(n=st.integers(2, 4), seed=st.integers(0, 10_000))
def test_expectation_plan_exact_matches_statevector(n, seed):
    qc = random_circuit(n, seed)
    obs = random_observable(n, 5, seed + 1)
    rows = np.random.default_rng(seed).uniform(-math.pi, math.pi, (3, qc.num_parameters))
    est = expectation_plan(qc, obs, rows).run(EXACT)
    assert est.value.shape == (3,) and est.standard_error.shape == (3,)
    np.testing.assert_allclose(est.value, exact_expectations(qc, obs, rows), atol=1e-10)
    np.testing.assert_array_equal(est.standard_error, 0.0)


def test_expectation_plan_accepts_one_row_and_labels():
    qc = hardware_efficient(3, 2, rotations=("rx", "ry"))
    values = np.linspace(-1, 1, qc.num_parameters)
    est = expectation_plan(qc, "XYZ", values).run(EXACT)
    expected = Statevector(qc.assign_parameters(values)).expectation_value(Pauli("XYZ")).real
    assert est.value.shape == (1,)
    assert est.value[0] == pytest.approx(expected, abs=1e-10)


@pytest.mark.parametrize(
    "labels,groups",
    [
        (["ZZZ", "ZIZ", "IZI"], 1),
        (["ZZZ", "ZIZ", "XXX", "XIX"], 2),
        (["ZZZ", "XXX", "YYY", "III"], 3),
        (["XYZ", "XYI", "IYZ", "XII"], 1),
        (["III"], 0),
    ],
)
def test_templates_are_qubit_wise_commuting_groups(labels, groups):
    qc = random_circuit(3, 7)
    obs = SparsePauliOp(labels, np.arange(1.0, len(labels) + 1))
    rows = np.random.default_rng(1).uniform(-2, 2, (2, qc.num_parameters))
    plan = expectation_plan(qc, obs, rows)
    assert plan.num_templates == groups
    assert plan.num_circuits == 2 * groups
    est = plan.run(EXACT)
    np.testing.assert_allclose(est.value, exact_expectations(qc, obs, rows), atol=1e-10)


def test_identity_only_observable_needs_no_circuit():
    qc = random_circuit(2, 0)
    plan = expectation_plan(qc, SparsePauliOp(["II"], [2.5]), np.zeros((4, qc.num_parameters)))
    assert plan.jobs == []
    np.testing.assert_allclose(plan.run(EXACT).value, [2.5] * 4)


def test_probabilities_plan_exact():
    qc = random_circuit(3, 3)
    rows = np.random.default_rng(3).uniform(-2, 2, (3, qc.num_parameters))
    res = probabilities_plan(qc, rows).run(EXACT)
    assert res.probabilities.shape == (3, 8)
    for r, p in zip(rows, res.probabilities, strict=True):
        np.testing.assert_allclose(p, Statevector(qc.assign_parameters(r)).probabilities(),
                                   atol=1e-12)


def test_exact_engine_unparameterised_template_several_rows():
    qc = QuantumCircuit(2)
    qc.h(0)
    qc.cx(0, 1)
    job = CircuitJob(measured(qc), np.zeros((3, 0)))
    (res,) = ExactEngine().run([job])
    np.testing.assert_allclose(res.probabilities, [[0.5, 0, 0, 0.5]] * 3, atol=1e-12)


@pytest.mark.parametrize("p", [0.05, 0.2])
def test_exact_density_matrix_engine_with_depolarising_noise(p):
    from qiskit_aer.noise import NoiseModel, depolarizing_error

    noise = NoiseModel()
    noise.add_all_qubit_quantum_error(depolarizing_error(p, 1), ["ry"])
    engine = ExactEngine(method="density_matrix", noise_model=noise)
    theta = ParameterVector("θ", 2)
    qc = QuantumCircuit(1)
    qc.ry(theta[0], 0)
    qc.ry(theta[1], 0)
    rows = np.array([[0.3, 0.4], [1.2, -2.0], [0.0, 0.0]])
    z = expectation_plan(qc, SparsePauliOp("Z"), rows).run(engine).value
    x = expectation_plan(qc, SparsePauliOp("X"), rows).run(engine).value
    total = rows.sum(axis=1)
    np.testing.assert_allclose(z, (1 - p) ** 2 * np.cos(total), atol=1e-10)
    np.testing.assert_allclose(x, (1 - p) ** 2 * np.sin(total), atol=1e-10)
    noiseless = expectation_plan(qc, SparsePauliOp("Z"), rows).run(EXACT).value
    np.testing.assert_allclose(noiseless, np.cos(total), atol=1e-10)


def test_exact_engine_bad_method():
    with pytest.raises(ValueError, match="method"):
        ExactEngine(method="mps")


# ---------------------------------------------------------------------------- sampler engine
# Each statistical check states its false-failure rate for a random seed and takes its seed
# from QDENSITY_STAT_SEED (benchmarks/fuzz_statistics.py runs them over 50 seeds).



def _binomial_ok(counts, shots: int, p, rate: float) -> np.ndarray:
    """Each count inside the central ``1 - rate`` of its exact Binomial(shots, p)."""
    return ((binom.ppf(rate / 2, shots, p) <= counts)
            & (counts <= binom.isf(rate / 2, shots, p)))


def test_sampler_engine_within_standard_errors_and_ledger():
    qc = random_circuit(3, 11)
    obs = SparsePauliOp(["ZZI", "IZZ", "XIX", "YYI", "III"], [0.8, -0.5, 1.1, 0.7, 0.3])
    rows = np.random.default_rng(11).uniform(-math.pi, math.pi, (5, qc.num_parameters))
    shots = 4000
    plan = expectation_plan(qc, obs, rows, shots=shots, label="obs")
    engine = SamplerEngine(seed=_stat_seed(1234))
    est = plan.run(engine)
    exact = exact_expectations(qc, obs, rows)
    assert np.all(est.standard_error > 0)
    # 5 estimates, each a sum of means over 4000 shots (normal; its standard error estimated
    # from the same shots): false failure 5 x 2 Phi(-4) = 3e-4
    assert np.all(np.abs(est.value - exact) <= 4 * est.standard_error)
    # the standard error is the one of a mean over `shots` samples: bounded by ||coeffs||_1
    assert np.all(est.standard_error <= (np.abs(obs.coeffs[:-1]).sum()) / math.sqrt(shots))
    # ledger: one entry per job, rows * shots each
    assert len(engine.ledger.entries) == plan.num_templates
    for entry, job in zip(engine.ledger.entries, plan.jobs, strict=True):
        assert entry.circuits == 5
        assert entry.shots == 5 * shots
        assert entry.label == job.label
    assert engine.ledger.total_shots == plan.total_shots == plan.num_templates * 5 * shots
    assert engine.ledger.total_circuits == plan.num_circuits
    assert engine.ledger.by_label() == {"obs": (plan.num_circuits, plan.total_shots)}
    # each template transpiled once, however often the plan runs
    assert engine.transpile_count == plan.num_templates
    plan.run(engine)
    plan.run(engine)
    assert engine.transpile_count == plan.num_templates
    assert engine.ledger.total_shots == 3 * plan.total_shots


def test_sampler_engine_same_seed_same_numbers():
    qc = random_circuit(2, 5)
    obs = SparsePauliOp(["ZX", "YI"], [1.0, -0.4])
    rows = np.random.default_rng(5).uniform(-2, 2, (3, qc.num_parameters))
    plan = expectation_plan(qc, obs, rows, shots=500)
    a = plan.run(SamplerEngine(seed=99))
    b = plan.run(SamplerEngine(seed=99))
    c = plan.run(SamplerEngine(seed=100))
    np.testing.assert_array_equal(a.value, b.value)
    np.testing.assert_array_equal(a.standard_error, b.standard_error)
    assert not np.array_equal(a.value, c.value)


def test_sampler_engine_unparameterised_template_several_rows():
    qc = QuantumCircuit(2)
    qc.h(0)
    qc.cx(0, 1)
    shots = 2000
    job = CircuitJob(measured(qc), np.zeros((3, 0)), shots=shots, label="bell")
    engine = SamplerEngine(seed=_stat_seed(4))
    (res,) = engine.run([job])
    assert res.probabilities.shape == (3, 4)
    np.testing.assert_allclose(res.probabilities.sum(axis=1), 1.0)
    assert np.all(res.probabilities[:, [1, 2]] == 0)
    # three counts of 00 inside the central 1 - 1e-4 of Binomial(2000, 1/2): rate 3e-4
    counts = np.rint(res.probabilities[:, 0] * shots)
    assert np.all(_binomial_ok(counts, shots, 0.5, 1e-4))
    # rows are sampled independently, not copied: three equal Binomial(2000, 1/2) counts have
    # probability sum_k P(k)^3 ~ 1 / (2 pi sigma^2 sqrt 3) = 2e-4 (sigma^2 = 500)
    assert len({tuple(p) for p in res.probabilities}) > 1
    assert engine.ledger.entries[-1].circuits == 3
    assert engine.ledger.entries[-1].shots == 3 * shots


def test_sampler_engine_template_whose_parameters_vanish_in_transpilation():
    # rz before a Z measurement is removed at optimisation level 3: the compiled PUB has no
    # parameters left, yet every row must still be sampled with its own shots
    t = Parameter("t")
    qc = QuantumCircuit(2)
    qc.h(0)
    qc.rz(t, 0)
    qc.h(1)
    shots = 1000
    plan = expectation_plan(qc, "ZZ", np.array([[0.1], [0.2], [0.3]]), shots=shots)
    est = plan.run(SamplerEngine(seed=_stat_seed(1), optimization_level=3))
    # exact <ZZ> = 0 for every t, single-shot variance 1: (1 + value) shots / 2 is
    # Binomial(1000, 1/2); three rows inside its central 1 - 1e-4: rate 3e-4
    assert np.all(_binomial_ok(np.rint((1 + est.value) * shots / 2), shots, 0.5, 1e-4))


def test_sampler_probabilities_plan_within_bounds():
    qc = random_circuit(3, 21)
    rows = np.random.default_rng(21).uniform(-2, 2, (2, qc.num_parameters))
    shots = 3000
    res = probabilities_plan(qc, rows, shots=shots).run(SamplerEngine(seed=_stat_seed(8)))
    assert res.shots == shots
    # 2 rows x 8 outcome counts, each inside the central 1 - 6e-5 of its exact binomial
    # (exact quantiles: some probabilities are small): false failure <= 16 x 6e-5 = 1e-3
    for r, freq in zip(rows, res.probabilities, strict=True):
        p = Statevector(qc.assign_parameters(r)).probabilities()
        assert np.all(_binomial_ok(np.rint(freq * shots), shots, p, 6e-5))


def test_default_shots_for_exact_jobs_on_sampler():
    qc = random_circuit(2, 1)
    plan = expectation_plan(qc, "ZZ", np.zeros(qc.num_parameters))
    engine = SamplerEngine(seed=0, default_shots=300)
    est = plan.run(engine)
    assert engine.ledger.total_shots == 300
    assert est.standard_error[0] > 0 or abs(est.value[0]) == 1.0


# ------------------------------------------------------------------------- post-processing


@settings(max_examples=20, deadline=None)
@given(num_bits=st.integers(1, 5), data=st.data())
def test_z_parities_brute_force(num_bits, data):
    masks = np.array(data.draw(st.lists(st.integers(0, 2**num_bits - 1), min_size=1,
                                        max_size=4)))
    signs = z_parities(masks, num_bits)
    assert signs.shape == (len(masks), 2**num_bits)
    for t, mask in enumerate(masks):
        for b in range(2**num_bits):
            assert signs[t, b] == (-1) ** bin(b & int(mask)).count("1")


@settings(max_examples=20, deadline=None)
@given(n=st.integers(1, 4), data=st.data())
def test_diagonal_values_brute_force(n, data):
    labels = data.draw(st.lists(st.text("IZ", min_size=n, max_size=n), min_size=1, max_size=4))
    phases = data.draw(st.lists(st.sampled_from(["", "-"]), min_size=len(labels),
                                max_size=len(labels)))
    coeffs = np.array(data.draw(st.lists(st.floats(-3, 3), min_size=len(labels),
                                         max_size=len(labels))))
    paulis = PauliList([s + lab for s, lab in zip(phases, labels, strict=True)])
    values = diagonal_values(paulis, coeffs, n)
    dense = sum(c * Pauli(s + lab).to_matrix()
                for c, s, lab in zip(coeffs, phases, labels, strict=True))
    np.testing.assert_allclose(values, np.real(np.diag(dense)), atol=1e-12)


def test_diagonal_values_refuses_non_diagonal():
    with pytest.raises(ValueError, match="Z-type"):
        diagonal_values(PauliList(["XZ"]), np.ones(1), 2)


@pytest.mark.parametrize(
    "labels",
    [["XYZ", "IYZ", "XII"], ["YY", "YI"], ["ZX", "IX", "ZI"], ["YXZI", "IXZY", "YIII"]],
)
def test_basis_rotation_maps_group_to_z_strings(labels):
    paulis = PauliList(labels)
    rot, images = basis_rotation(paulis)
    v = Operator(rot).data
    assert set(rot.count_ops()) <= {"h", "sdg"}
    for pauli, image in zip(paulis, images, strict=True):
        assert not np.any(image.x)
        expected = "".join("I" if c == "I" else "Z" for c in pauli.to_label())
        assert image.to_label() == expected
        np.testing.assert_allclose(v @ pauli.to_matrix() @ v.conj().T,
                                   Pauli(expected).to_matrix(), atol=1e-12)


def test_basis_rotation_refuses_non_qubit_wise_commuting():
    with pytest.raises(ValueError, match="qubit 1"):
        basis_rotation(PauliList(["XZ", "ZZ"]))


# ------------------------------------------------------------------------------- bad input


def test_bad_input():
    qc = random_circuit(2, 0)
    p = qc.num_parameters
    with pytest.raises(ValueError, match=rf"\(rows, {p}\)"):
        expectation_plan(qc, "ZZ", np.zeros((3, p + 1)))
    with pytest.raises(ValueError, match=rf"\({p},\)"):
        probabilities_plan(qc, np.zeros(p - 1))
    with pytest.raises(ValueError, match="finite"):
        expectation_plan(qc, "ZZ", np.full(p, np.nan))
    with pytest.raises(ValueError, match="3 qubits"):
        expectation_plan(qc, "ZZZ", np.zeros(p))
    with pytest.raises(ValueError, match="Hermitian"):
        expectation_plan(qc, SparsePauliOp(["ZZ"], [1j]), np.zeros(p))
    with pytest.raises(TypeError, match="observable"):
        expectation_plan(qc, object(), np.zeros(p))
    with pytest.raises(ValueError, match="shots"):
        expectation_plan(qc, "ZZ", np.zeros(p), shots=0)
    with pytest.raises(TypeError, match="shots"):
        expectation_plan(qc, "ZZ", np.zeros(p), shots=1.5)
    with pytest.raises(ValueError, match="shots"):
        expectation_plan(qc, "ZZ", np.zeros(p)).with_shots(-3)
    with pytest.raises(ValueError, match="classical bits"):
        CircuitJob(qc, np.zeros(p))
    with pytest.raises(TypeError, match="circuit"):
        expectation_plan("not a circuit", "ZZ", np.zeros(p))
    with pytest.raises(TypeError, match="sampler"):
        SamplerEngine(sampler=object())


def test_plan_with_shots_and_combine():
    qc = random_circuit(2, 2)
    rows = np.random.default_rng(2).uniform(-1, 1, (2, qc.num_parameters))
    a = expectation_plan(qc, SparsePauliOp(["ZZ", "XX"], [1.0, 0.5]), rows)
    b = probabilities_plan(qc, rows)
    assert a.total_shots is None
    assert a.with_shots(100).total_shots == 2 * 2 * 100
    both = Plan.combine([a, b])
    assert both.num_templates == a.num_templates + b.num_templates
    est, res = both.run(EXACT)
    np.testing.assert_allclose(
        est.value, exact_expectations(qc, SparsePauliOp(["ZZ", "XX"], [1.0, 0.5]), rows),
        atol=1e-10)
    np.testing.assert_allclose(
        res.probabilities[1], Statevector(qc.assign_parameters(rows[1])).probabilities(),
        atol=1e-12)


def test_postselect_hamming_weight_on_noisy_unary_circuit():
    """Readout noise leaks weight out of the unary subspace; post-selection reports the kept
    fraction and recovers the unary distribution closely."""
    from qiskit import transpile
    from qiskit_aer import AerSimulator
    from qiskit_aer.noise import NoiseModel, ReadoutError
    from qiskit_aer.primitives import SamplerV2

    from qdensity.circuits.loaders import unary_loader
    from qdensity.execution.plans import postselect_hamming_weight, probabilities_plan

    x = np.array([0.5, -0.3, 0.8, 0.1])
    circ = unary_loader(x)
    nm = NoiseModel()
    nm.add_all_qubit_readout_error(ReadoutError([[0.97, 0.03], [0.03, 0.97]]))
    engine = SamplerEngine(SamplerV2(seed=_stat_seed(5),
                                     options={"backend_options": {"noise_model": nm}}),
                           transpiler=lambda c: transpile(c, AerSimulator()))
    res = probabilities_plan(circ, None, shots=20000).run(engine)
    post, kept = postselect_hamming_weight(res.probabilities)
    # P(no flip on all 4 qubits) plus the two-flip terms that stay at weight one:
    # 0.97**4 + 3 x 0.03**2 x 0.97**2 = 0.888; binomial sd over 20000 shots 0.0022, so the
    # bounds are 10 sd away (false failure < 1e-20)
    assert 0.86 < kept[0] < 0.91
    want = (x / np.linalg.norm(x)) ** 2
    # the two-flip terms bias each post-selected entry by < 0.001; its sampling sd is
    # <= sqrt(0.25 / 17700) = 0.0038, so 0.02 is >= 5 sd: false failure 4 x 2 Phi(-5) = 3e-6
    np.testing.assert_allclose(post[0, 1 << np.arange(4)], want, atol=0.02)
    with pytest.raises(ValueError, match="keep no outcome"):
        postselect_hamming_weight(np.array([[1.0, 0, 0, 0]]))
