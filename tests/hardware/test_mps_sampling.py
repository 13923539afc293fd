"""Sampling past the statevector's width with Aer's matrix-product-state method (README).

A unary state has Schmidt rank <= 2 across every cut, so MPS samples RBS circuits on unary
inputs at widths a statevector cannot hold; its estimates must agree with the exact unary
engine and with finite differences of it.
"""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit.quantum_info import SparsePauliOp
from qiskit_aer.primitives import SamplerV2
from scipy.stats import binom

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.gradients import density_gradient_plan

N, SHOTS = 30, 2000



def _model() -> DensityQNN:
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], N)
    subs = by_moments(round_robin(N)).sub_unitaries[:2]
    return DensityQNN(subs, encoding=Encoding.unary(N), observable=obs, seed=3)


def test_mps_sampled_outputs_and_gradients_at_30_qubits_match_the_unary_engine():
    model = _model()
    X = np.random.default_rng(4).normal(size=(2, N))
    X[:, :4] *= 5  # weight near qubit 0, which Z_0 reads: derivatives well above the noise
    plan = density_gradient_plan(model, X, method="commuting", shots=SHOTS)
    mps = SamplerV2(seed=_stat_seed(0),
                    options={"backend_options": {"method": "matrix_product_state"}})
    grad = plan.run(SamplerEngine(mps, seed=_stat_seed(0), progress=False))
    exact = model.expert_outputs(X, method="unary")  # (B, K), no 2**30 array
    # <Z_0> = 1 - 2p: binomial error of the exact p (never 0). False failure: 4 outputs and
    # fewer than 200 derivative entries at 5 standard errors (normal, 2000 shots):
    # < 204 x 5.7e-7 = 1.2e-4
    assert sum(j[:, 0].size for j in grad.jacobians) < 200
    p = (1.0 - exact) / 2.0
    se = 2.0 * np.sqrt(np.maximum(p * (1.0 - p), 1.0 / SHOTS) / SHOTS)
    assert np.all(np.abs(grad.outputs[..., 0] - exact) <= 5 * se)
    theta, h = model.theta.copy(), 1e-6
    largest = 0.0
    for k, jac in enumerate(grad.jacobians):
        idx = model.subunitary_parameter_indices(k)
        for c, i in enumerate(idx):
            up, down = theta.copy(), theta.copy()
            up[i] += h
            down[i] -= h
            fd = (model.expert_outputs(X, up, method="unary")[:, k]
                  - model.expert_outputs(X, down, method="unary")[:, k]) / (2 * h)
            # 5 standard errors; an entry with error 0 has every shot agree (the parameter
            # does not reach qubit 0 from this input): there the derivative is 0 too
            bound = 5 * grad.jacobian_errors[k][:, 0, c] + 1e-6
            assert np.all(np.abs(jac[:, 0, c] - fd) <= bound)
            largest = max(largest, float(np.max(np.abs(fd) / (bound + 1e-12))))
    assert largest > 2  # some derivatives stand well clear of their error bars


def test_default_engine_picks_mps_for_unary_probabilities_at_32_qubits():
    """No sampler given: the engine's Aer sampler sees a Hamming-weight-1 circuit and runs it as
    matrix-product states; unary probabilities come from the measured bits (no 2**32 table)."""
    from qdensity.circuits.loaders import unary_loader
    from qdensity.execution.plans import probabilities_plan, unary_frequencies
    from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY

    n, shots = 32, 4000
    x = np.random.default_rng(1).normal(size=n)
    x[:3] *= 4
    engine = SamplerEngine(seed=_stat_seed(0), progress=False)
    res = probabilities_plan(unary_loader(x), [], shots=shots).run(engine)
    compiled = engine.compiled(res.job.circuit)
    assert compiled.metadata[HAMMING_WEIGHT_KEY] == 1
    assert engine.sampler.choose(compiled, shots)["method"] == "matrix_product_state"
    assert np.all(res.bits[0].sum(axis=1) == 1)  # noiseless: every shot has weight 1
    p, kept = unary_frequencies(res)
    assert kept[0] == 1.0
    # clbit j reads qubit j, which carries x_j (the loader's statevector is x / ||x|| on the
    # unary basis): count j ~ Binomial(4000, x_j**2 / ||x||**2). Each of the 32 counts inside
    # the central 1 - 3e-5 of its exact binomial (exact quantiles: most p_j are small; a
    # discrete tail holds at most its nominal mass): false failure <= 32 x 3e-5 < 1e-3
    exact = x**2 / np.sum(x**2)
    counts = np.rint(p[0] * shots)
    assert np.all((binom.ppf(1.5e-5, shots, exact) <= counts)
                  & (counts <= binom.isf(1.5e-5, shots, exact)))


def test_a_state_that_cannot_fit_is_refused_before_aer_allocates_it():
    from qiskit import QuantumCircuit

    from qdensity.execution.plans import CircuitJob
    from qdensity.hardware.aer_sampling import memory_budget

    n = 30
    while 16 * 2**n <= memory_budget():  # wider than this machine's budget, whatever it is
        n += 1
    qc = QuantumCircuit(n)
    for q in range(n):
        qc.ry(0.1 * (q + 1), q)
    for q in range(n - 1):
        qc.cx(q, q + 1)
    qc.cx(0, n - 1)  # not neighbours on the line: no proven bond bound, so no MPS either
    qc.measure_all()
    engine = SamplerEngine(seed=0, progress=False)
    job = CircuitJob(qc, np.zeros((1, 0)), 10)
    pattern = rf"SamplerEngine.*automatic method on {n} active qubits needs.*matrix_product_state"
    with pytest.raises(ValueError, match=pattern):
        engine.run([job])
    assert engine.ledger.total_shots == 0
    plain = SamplerEngine(SamplerV2(seed=0), progress=False)  # a plain Aer sampler too
    with pytest.raises(ValueError, match=rf"{n} active qubits needs"):
        plain.run([job])
