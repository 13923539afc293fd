"""Oracle tests for parameter-shift gradient plans (``qdensity.gradients.shift``, Supp. E eq. 23).

Oracles: central finite differences of exact ``Statevector`` expectations and probabilities,
the circuit count of the rules written out by hand (4 per RBS/FBS occurrence, 2 per Pauli
rotation occurrence, times rows and measurement groups), and, for sampled gradients, a bound of
four standard errors around the exact gradient at a fixed seed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit.circuit import Parameter, ParameterVector, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.gates import RBSGate
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.shift import expand_occurrences, parameter_shift_plan, shift_rules

EXACT = ExactEngine()
H = 1e-5


def fd_expectation(circuit, observable, rows) -> np.ndarray:
    """Central finite differences of exact expectations, shape (B, P)."""
    def f(v):
        return Statevector(circuit.assign_parameters(v)).expectation_value(observable).real

    out = np.zeros(rows.shape)
    for b, row in enumerate(rows):
        for k in range(rows.shape[1]):
            e = np.zeros(rows.shape[1])
            e[k] = H
            out[b, k] = (f(row + e) - f(row - e)) / (2 * H)
    return out


def fd_probabilities(circuit, rows) -> np.ndarray:
    """Central finite differences of exact probabilities, shape (B, 2**n, P)."""
    def f(v):
        return Statevector(circuit.assign_parameters(v)).probabilities()

    out = np.zeros((rows.shape[0], 2**circuit.num_qubits, rows.shape[1]))
    for b, row in enumerate(rows):
        for k in range(rows.shape[1]):
            e = np.zeros(rows.shape[1])
            e[k] = H
            out[b, :, k] = (f(row + e) - f(row - e)) / (2 * H)
    return out


def random_observable(n: int, terms: int, seed: int) -> SparsePauliOp:
    rng = np.random.default_rng(seed)
    labels = ["".join(rng.choice(list("IXYZ"), n)) for _ in range(terms)]
    labels[0] = "X" + "Y" * (n - 1)  # certainly non-diagonal
    return SparsePauliOp(labels, rng.normal(size=terms))


def unary_input_then(body: QuantumCircuit, seed: int) -> QuantumCircuit:
    """A fixed unary state (x on qubit 0, then a chain of bound RBS) followed by ``body``."""
    n = body.num_qubits
    angles = np.random.default_rng(seed).uniform(-math.pi, math.pi, n - 1)
    qc = QuantumCircuit(n)
    qc.x(0)
    for k in range(n - 1):
        qc.append(RBSGate(float(angles[k])), [k, k + 1])
    return qc.compose(body)


@pytest.mark.parametrize("n", [4, 5])
def test_four_term_rule_equals_finite_differences_on_pyramid(n):
    qc = unary_input_then(pyramid(n), seed=n)
    obs = random_observable(n, 4, seed=n)
    rows = np.random.default_rng(10 + n).uniform(-math.pi, math.pi, (2, qc.num_parameters))
    est = parameter_shift_plan(qc, obs, rows).run(EXACT)
    assert est.value.shape == (2, qc.num_parameters)
    np.testing.assert_allclose(est.value, fd_expectation(qc, obs, rows), atol=1e-8)
    np.testing.assert_array_equal(est.standard_error, 0.0)


def test_four_term_rule_for_fbs_gates():
    qc = unary_input_then(round_robin(4, gate="fbs"), seed=3)
    qc.h(1)  # leave the unary subspace so that the FBS parity matters
    obs = random_observable(4, 3, seed=8)
    rows = np.random.default_rng(8).uniform(-math.pi, math.pi, (1, qc.num_parameters))
    est = parameter_shift_plan(qc, obs, rows).run(EXACT)
    np.testing.assert_allclose(est.value, fd_expectation(qc, obs, rows), atol=1e-8)


def _single_rbs_circuit(extra_gate: bool) -> QuantumCircuit:
    t = Parameter("t")
    qc = QuantumCircuit(3)  # a generic entangled state: weight on every RBS eigenspace
    qc.ry(0.7, 0)
    qc.ry(-1.1, 1)
    qc.ry(0.4, 2)
    qc.cx(0, 1)
    qc.cx(1, 2)
    qc.ry(0.5, 0)
    qc.rx(1.3, 1)
    qc.append(RBSGate(t), [0, 1])
    if extra_gate:
        qc.ry(0.9, 1)  # a later gate on one of the RBS qubits
    return qc


def test_two_term_rule_exact_for_final_rbs_and_diagonal_observable():
    qc = _single_rbs_circuit(extra_gate=False)
    obs = SparsePauliOp(["IIZ", "IZI", "IZZ", "ZZI"], [1.0, -0.6, 0.8, 0.3])
    rows = np.array([[0.3], [-1.4], [2.2]])
    fd = fd_expectation(qc, obs, rows)
    assert np.abs(fd).max() > 0.1
    two = parameter_shift_plan(qc, obs, rows, rbs_rule="two_term").run(EXACT).value
    four = parameter_shift_plan(qc, obs, rows).run(EXACT).value
    np.testing.assert_allclose(two, fd, atol=1e-8)
    np.testing.assert_allclose(four, fd, atol=1e-8)


def test_two_term_rule_wrong_when_a_later_gate_touches_the_rbs():
    qc = _single_rbs_circuit(extra_gate=True)
    obs = SparsePauliOp(["IIZ", "IZI", "IZZ", "ZZI"], [1.0, -0.6, 0.8, 0.3])
    rows = np.array([[0.3], [-1.4], [2.2]])
    fd = fd_expectation(qc, obs, rows)
    two = parameter_shift_plan(qc, obs, rows, rbs_rule="two_term").run(EXACT).value
    four = parameter_shift_plan(qc, obs, rows).run(EXACT).value
    np.testing.assert_allclose(four, fd, atol=1e-8)
    assert np.abs(two - fd).max() > 1e-3


def test_two_term_rule_wrong_for_non_diagonal_observable():
    qc = _single_rbs_circuit(extra_gate=False)
    obs = SparsePauliOp(["IXI", "IIY"], [1.0, 0.5])
    rows = np.array([[0.3], [-1.4]])
    fd = fd_expectation(qc, obs, rows)
    two = parameter_shift_plan(qc, obs, rows, rbs_rule="two_term").run(EXACT).value
    np.testing.assert_allclose(parameter_shift_plan(qc, obs, rows).run(EXACT).value, fd,
                               atol=1e-8)
    assert np.abs(two - fd).max() > 1e-3


def _pauli_rotation_circuit() -> QuantumCircuit:
    p = ParameterVector("p", 3)
    qc = QuantumCircuit(3)
    qc.h(2)
    qc.rx(2 * p[0] + 0.3, 0)
    qc.ry(2 * p[0] + 0.3, 1)  # p[0] shared by several gates
    qc.cx(0, 2)
    qc.append(PauliEvolutionGate(SparsePauliOp("XZ", 0.7), time=p[1]), [2, 0])
    qc.ry(-0.5 * p[2], 2)
    qc.rz(p[0], 1)
    qc.append(RBSGate(p[2]), [1, 2])
    return qc


def test_pauli_rotations_shared_parameters_and_evolutions():
    qc = _pauli_rotation_circuit()
    obs = SparsePauliOp(["XYZ", "ZIX", "IYY"], [0.9, -0.4, 1.3])
    rows = np.random.default_rng(4).uniform(-math.pi, math.pi, (2, 3))
    plan = parameter_shift_plan(qc, obs, rows)
    np.testing.assert_allclose(plan.run(EXACT).value, fd_expectation(qc, obs, rows), atol=1e-8)
    # 3 occurrences of p[0], 1 evolution, 1 ry and 1 RBS for p[2]
    assert plan.meta["occurrences"] == 6
    assert plan.num_circuits == 2 * (2 * 3 + 2 + 2 + 4) * 3
    rules = shift_rules(qc)
    assert [len(r.shifts) for _, _, r in rules] == [2, 2, 2, 2, 2, 4]
    assert rules[2][2].shifts[0] == pytest.approx(math.pi / (4 * 0.7))
    assert [a for _, a, _ in rules] == pytest.approx([2.0, 2.0, 1.0, -0.5, 1.0, 1.0])


def test_parameters_subset_orders_columns():
    qc = _pauli_rotation_circuit()
    obs = SparsePauliOp("ZZZ")
    rows = np.random.default_rng(6).uniform(-math.pi, math.pi, (1, 3))
    params = list(qc.parameters)
    sub = [params[2], params[0]]
    est = parameter_shift_plan(qc, obs, rows, parameters=sub).run(EXACT)
    fd = fd_expectation(qc, obs, rows)
    np.testing.assert_allclose(est.value, fd[:, [2, 0]], atol=1e-8)


def test_probabilities_mode_equals_finite_differences():
    qc = unary_input_then(pyramid(3), seed=1)
    qc.ry(ParameterVector("q", 1)[0], 1)
    rows = np.random.default_rng(2).uniform(-math.pi, math.pi, (2, qc.num_parameters))
    est = parameter_shift_plan(qc, None, rows).run(EXACT)
    assert est.value.shape == (2, 8, qc.num_parameters)
    np.testing.assert_allclose(est.value, fd_probabilities(qc, rows), atol=1e-8)
    np.testing.assert_allclose(est.value.sum(axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("rows", [1, 3])
def test_circuit_counts(rows):
    body = pyramid(4)
    a = Parameter("a")
    qc = QuantumCircuit(4)
    qc.rx(a, 0)
    qc.compose(body, inplace=True)
    qc.ry(2 * Parameter("b"), 3)
    qc.rz(-a, 2)
    num_rbs, num_pauli = 6, 3
    obs = SparsePauliOp(["ZZZZ", "XXII", "IIXI", "IIII"], [1.0, 0.5, 0.2, 3.0])  # 2 groups
    values = np.zeros((rows, qc.num_parameters))
    plan = parameter_shift_plan(qc, obs, values)
    assert plan.num_templates == 2
    assert plan.num_circuits == rows * (4 * num_rbs + 2 * num_pauli) * 2
    prob = parameter_shift_plan(qc, None, values)
    assert prob.num_templates == 1
    assert prob.num_circuits == rows * (4 * num_rbs + 2 * num_pauli)
    two = parameter_shift_plan(qc, obs, values, rbs_rule="two_term")
    assert two.num_circuits == rows * (2 * num_rbs + 2 * num_pauli) * 2



def test_sampled_gradient_within_standard_errors():
    qc = unary_input_then(pyramid(3), seed=5)
    obs = SparsePauliOp(["XYI", "ZZZ", "IIZ"], [0.8, 0.5, -0.3])
    rows = np.random.default_rng(5).uniform(-math.pi, math.pi, (2, qc.num_parameters))
    exact = parameter_shift_plan(qc, obs, rows).run(EXACT).value
    np.testing.assert_allclose(exact, fd_expectation(qc, obs, rows), atol=1e-8)
    plan = parameter_shift_plan(qc, obs, rows, shots=3000)
    engine = SamplerEngine(seed=_stat_seed(2024))
    est = plan.run(engine)
    assert np.all(est.standard_error > 0)
    # Bonferroni over the 2 x 3 gradient entries and 8 probabilities at 4 standard errors:
    # false failure <= 14 x 2 Phi(-4) = 1e-3 for normal estimates
    assert np.all(np.abs(est.value - exact) <= 4 * est.standard_error)
    assert engine.ledger.total_shots == plan.num_circuits * 3000
    probs = parameter_shift_plan(qc, None, rows[:1], shots=3000).run(
        SamplerEngine(seed=_stat_seed(7)))
    exact_p = fd_probabilities(qc, rows[:1])
    assert np.all(np.abs(probs.value - exact_p) <= 4 * probs.standard_error + 1e-3)


def test_expand_occurrences_rewrites_each_occurrence():
    qc = _pauli_rotation_circuit()
    expanded, occ = expand_occurrences(qc)
    assert len(occ) == 6 == expanded.num_parameters
    assert [o[0].name for o in occ] == ["p[0]", "p[0]", "p[1]", "p[2]", "p[0]", "p[2]"]
    # same unitary when every occurrence gets its parameter's value
    values = np.array([0.3, -0.8, 1.9])
    index = {p: i for i, p in enumerate(qc.parameters)}
    fresh = {q: values[index[p]] for p, q, _, _ in occ}
    a = Statevector(qc.assign_parameters(values))
    b = Statevector(expanded.assign_parameters(fresh))
    assert a.equiv(b)


def test_shift_errors():
    qc = _pauli_rotation_circuit()
    with pytest.raises(ValueError, match="rbs_rule"):
        parameter_shift_plan(qc, SparsePauliOp("ZZZ"), np.zeros(3), rbs_rule="three_term")
    with pytest.raises(ValueError, match="not in the circuit"):
        parameter_shift_plan(qc, SparsePauliOp("ZZZ"), np.zeros(3), parameters=[Parameter("z")])
    with pytest.raises(ValueError, match=r"\(rows, 3\)"):
        parameter_shift_plan(qc, SparsePauliOp("ZZZ"), np.zeros((2, 4)))
    # XX + 0.5 ZZ has four distinct eigenvalues: no two- or four-term rule
    four_levels = QuantumCircuit(2)
    four_levels.append(PauliEvolutionGate(SparsePauliOp(["XX", "ZZ"], [1.0, 0.5]),
                                          time=Parameter("t")), [0, 1])
    with pytest.raises(ValueError, match="eigenvalues"):
        parameter_shift_plan(four_levels, SparsePauliOp("ZZ"), np.zeros(1))


def test_spectral_rule_for_equally_spaced_generator():
    """XX + ZZ has eigenvalues {-2, 0, 0, 2}: the four-term rule with angles scaled by 2 is
    exact (checked against central finite differences of exact statevectors)."""
    t = Parameter("t")
    qc = QuantumCircuit(2)
    qc.h(0)
    qc.ry(0.4, 1)
    qc.append(PauliEvolutionGate(SparsePauliOp(["XX", "ZZ"]), time=t), [0, 1])
    obs = SparsePauliOp(["XZ", "YI"], [0.7, 0.3])
    vals = np.array([[0.3], [-1.1]])
    grad = parameter_shift_plan(qc, obs, vals).run(ExactEngine()).value
    eps = 1e-6

    def f(v):
        return Statevector(qc.assign_parameters([v])).expectation_value(obs).real

    fd = [(f(v + eps) - f(v - eps)) / (2 * eps) for v in vals[:, 0]]
    np.testing.assert_allclose(grad[:, 0], fd, atol=1e-7)


def test_sampled_unary_readout_gradient_reads_the_bits_never_a_dense_row(monkeypatch):
    """A unary-probabilities model's sampled shift gradient (``density_gradient_plan``) takes
    its n outcome frequencies off the measured bits: no ``2**n`` row is built (the dense path
    is made to fail), and the estimates agree with central differences of the exact unary
    engine."""
    from qdensity import DensityQNN, Encoding
    from qdensity.execution import job_results
    from qdensity.gradients import density_gradient_plan

    n, shots = 4, 4000
    model = DensityQNN([pyramid(n, parameter_prefix="a"), round_robin(n, parameter_prefix="b")],
                       encoding=Encoding.unary(n), readout="unary_probabilities", seed=2)
    X = np.random.default_rng(6).normal(size=(2, n))

    def dense(*_a, **_k):
        raise AssertionError("a dense 2**n row was built from the bits")

    monkeypatch.setattr(job_results, "bits_to_probabilities", dense)
    grad = density_gradient_plan(model, X, method="shift", shots=shots).run(
        SamplerEngine(seed=_stat_seed(11), progress=False))
    theta = model.theta.copy()
    count = 0
    for k, jac in enumerate(grad.jacobians):
        assert jac.shape == (2, n, len(model.subunitary_parameter_indices(k)))
        for c, i in enumerate(model.subunitary_parameter_indices(k)):
            up, down = theta.copy(), theta.copy()
            up[i] += H
            down[i] -= H
            fd = (model.expert_outputs(X, up, method="unary")[:, k]
                  - model.expert_outputs(X, down, method="unary")[:, k]) / (2 * H)
            se = grad.jacobian_errors[k][:, :, c]
            # Bonferroni over < 100 entries at 5 standard errors (each a sum of four binomial
            # frequencies, normal at 4000 shots): false failure < 100 x 5.7e-7 = 6e-5; an entry
            # with error 0 had every shot agree, where the derivative is 0 too
            assert np.all(np.abs(jac[:, :, c] - fd) <= 5 * se + 1e-6)
            count += fd.size
    assert count < 100
