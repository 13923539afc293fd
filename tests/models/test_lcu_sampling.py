"""The sampled LCU path: lcu_template, post-selected estimates from bits, LCUQNN.sample."""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit.quantum_info import Operator, Statevector

from qdensity.circuits.ansatze import pyramid, round_robin
from qdensity.circuits.loaders import loader_angles
from qdensity.circuits.preparation import lcu_circuit, lcu_template
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import JobResult
from qdensity.execution.sampler.postselection import postselected_unary
from qdensity.models.decompositions import by_moments
from qdensity.models.lcu import LCUQNN
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture


def _bound_subs(subs, rng):
    values = {p: rng.uniform(-np.pi, np.pi) for s in subs for p in s.parameters}
    return values, [s.assign_parameters({p: values[p] for p in s.parameters}) for s in subs]


def test_lcu_template_bound_equals_lcu_circuit():
    rng = np.random.default_rng(4)
    subs = [round_robin(3, parameter_prefix=c) for c in "abcd"]
    values, bound = _bound_subs(subs, rng)
    alpha = rng.dirichlet(np.ones(4))
    tpl = lcu_template(subs)
    mix = {p: a for p, a in zip([p for p in tpl.parameters if p.name.startswith("ψ")],
                                loader_angles(np.sqrt(alpha)), strict=True)}
    got = Operator(tpl.assign_parameters({**values, **mix})).data
    assert np.allclose(got, Operator(lcu_circuit(bound, alpha)).data, atol=1e-10)


def test_lcu_template_postselected_state_is_normalised_lcu():
    # oracle: A|x> = sum_k alpha_k U_k |x> from the sub-unitaries' own operators
    rng = np.random.default_rng(5)
    subs = [pyramid(3, parameter_prefix=c) for c in "ab"]
    values, bound = _bound_subs(subs, rng)
    alpha = np.array([0.3, 0.7])
    tpl = lcu_template(subs)
    psi = [p for p in tpl.parameters if p.name.startswith("ψ")]
    state = Statevector(tpl.assign_parameters({**values, psi[0]: loader_angles(
        np.sqrt(alpha))[0]})).data[::4]
    x = np.zeros(8)
    x[0] = 1.0
    want = sum(a * Operator(b).data @ x for a, b in zip(alpha, bound, strict=True))
    assert np.allclose(state, want, atol=1e-10)


def test_lcu_template_refuses_one_subunitary():
    with pytest.raises(ValueError, match="K >= 2"):
        lcu_template([pyramid(3)])


def test_postselected_unary_counts_by_hand():
    # clbit 0 = mix; clbits 1, 2 = data. Shots: success e0, fail, success e1, success e0,
    # success with data 00 (non-unary, kept in the success count only)
    bits = np.array([[[0, 1, 0], [1, 1, 0], [0, 0, 1], [0, 1, 0], [0, 0, 0]]], dtype=bool)
    est = postselected_unary(JobResult(bits=bits, shots=5), [0], [1, 2])
    assert est.successes.tolist() == [4]
    assert est.success_probability.tolist() == [0.8]
    assert np.allclose(est.probabilities, [[0.5, 0.25]])
    p = np.array([0.5, 0.25])
    assert np.allclose(est.standard_error, np.sqrt(p * (1 - p) / 4 + 1 / 64))
    assert np.allclose(est.success_standard_error, np.sqrt(0.8 * 0.2 / 5 + 1 / 100))


def test_postselected_unary_no_success_is_nan_and_bad_input():
    bits = np.ones((1, 3, 3), dtype=bool)
    est = postselected_unary(JobResult(bits=bits, shots=3), [0], [1, 2])
    assert np.all(np.isnan(est.probabilities)) and est.success_probability[0] == 0.0
    assert est.success_standard_error[0] > 0
    with pytest.raises(ValueError, match="share"):
        postselected_unary(JobResult(bits=bits, shots=3), [0], [0, 1])
    with pytest.raises(ValueError, match="postselect"):
        postselected_unary(JobResult(bits=bits, shots=3), [5], [1, 2])


def _gated_model(n=4, seed=0):
    dec = by_moments(round_robin(n))
    return LCUQNN(dec.sub_unitaries, GatedMixture(n, dec.num_subunitaries, seed=seed + 1),
                  seed=seed)


def test_exact_plan_matches_lcuqnn():
    lcu = _gated_model()
    X = np.random.default_rng(0).normal(size=(3, 4))
    est = lcu.sampling_plan(X, None).run(ExactEngine())
    assert np.allclose(est.probabilities, lcu.predict(X), atol=1e-10)
    assert np.allclose(est.success_probability, lcu.success_probability(X), atol=1e-10)



@pytest.mark.parametrize("seed", [3, 11])
def test_sampled_estimates_within_standard_errors(seed):
    # 12 probabilities + 3 success probabilities per seed; each within 4.5 standard errors:
    # for normal estimates a false failure has probability <= 15 x 2 Phi(-4.5) = 1e-4
    lcu = _gated_model(seed=seed)
    X = np.random.default_rng(seed).normal(size=(3, 4))
    est = lcu.sample(X, 4000, seed=_stat_seed(seed))
    assert est.shots == 4000 and np.all(est.successes > 0)
    z_p = (est.probabilities - lcu.predict(X)) / est.standard_error
    z_s = (est.success_probability - lcu.success_probability(X)) / est.success_standard_error
    assert np.all(np.abs(z_p) < 4.5) and np.all(np.abs(z_s) < 4.5)
    assert np.allclose(est.probabilities.sum(axis=1), 1.0)  # noiseless: data stays unary


def test_fixed_mixture_plan_counts_and_rows():
    dec = by_moments(round_robin(4))
    lcu = LCUQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), seed=2)
    plan = lcu.sampling_plan(np.ones((5, 4)), 64)
    assert plan.num_templates == 1 and plan.num_circuits == 5 and plan.total_shots == 320
    assert plan.jobs[0].circuit.num_qubits == 4 + dec.num_subunitaries
    single = LCUQNN([round_robin(4)], seed=0)
    with pytest.raises(ValueError, match="K >= 2"):
        single.sampling_plan(np.ones((1, 4)), 10)
