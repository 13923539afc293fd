"""Estimates from sampled bits: never a 2**n array, agreeing with exact values (issue: scale)."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.circuit import QuantumCircuit
from qiskit.primitives import BitArray
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity import DensityQNN, Encoding, by_moments
from qdensity.analysis.pauli import MAX_DENSE_QUBITS
from qdensity.circuits.ansatze import round_robin
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import (
    CircuitJob,
    JobResult,
    bits_to_probabilities,
    expectation_plan,
    unary_frequencies,
)
from qdensity.execution.sampler.engine import (
    SamplerEngine,
    bitarray_to_bits,
    bitarray_to_probabilities,
)
from qdensity.gradients import density_gradient_plan


def test_bitarray_to_bits_matches_bitstrings():
    rng = np.random.default_rng(0)
    strings = ["".join(rng.choice(["0", "1"], size=11)) for _ in range(12)]
    ba = BitArray.from_samples(strings, num_bits=11).reshape(3, 4)
    bits = bitarray_to_bits(ba, 3, 4)
    assert bits.shape == (3, 4, 11)
    for k, s in enumerate(strings):  # a bitstring's last character is clbit 0
        np.testing.assert_array_equal(bits.reshape(12, 11)[k], [c == "1" for c in s[::-1]])
    probs = bitarray_to_probabilities(ba, 3, 4)
    ints = [int(s, 2) for s in strings]
    for r in range(3):
        want = np.bincount(ints[4 * r:4 * r + 4], minlength=2**11) / 4
        np.testing.assert_allclose(probs[r], want)


def test_dense_frequencies_refused_above_documented_width():
    bits = np.zeros((1, 2, MAX_DENSE_QUBITS + 1), bool)
    with pytest.raises(ValueError, match="MAX_DENSE_QUBITS"):
        bits_to_probabilities(bits)
    res = JobResult(None, 2, None, bits=bits)
    with pytest.raises(ValueError, match="estimate from the sampled bits"):
        _ = res.probabilities
    p, kept = unary_frequencies(res)  # from the bits: fine at any width
    assert p.shape == (1, MAX_DENSE_QUBITS + 1) and kept[0] == 0.0


def test_exact_engine_names_the_alternatives_above_its_width():
    qc = QuantumCircuit(MAX_DENSE_QUBITS + 1)
    qc.measure_all()
    with pytest.raises(ValueError, match="ExactEngine.*SamplerEngine.*unary.*matrix_product"):
        ExactEngine().run([CircuitJob(qc, np.zeros((1, 0)), None, "wide")])


def test_expectation_from_bits_within_standard_errors():
    qc = round_robin(4)
    qc.x(0)
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("XX", [1, 2], 0.5)], 4)
    rng = np.random.default_rng(1)
    values = rng.normal(size=(3, qc.num_parameters))
    est = expectation_plan(qc, obs, values, shots=4000).run(SamplerEngine(seed=3))
    for r in range(3):  # oracle: statevector expectation
        exact = Statevector(qc.assign_parameters(values[r])).expectation_value(obs).real
        assert abs(est.value[r] - exact) < 5 * est.standard_error[r] + 1e-9


def test_sampled_density_gradient_from_bits_agrees_with_exact():
    n = 5
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(n), observable=obs, seed=0)
    X = np.random.default_rng(2).normal(size=(2, n))
    exact = density_gradient_plan(model, X, method="commuting").run(ExactEngine())
    sampled = density_gradient_plan(model, X, method="commuting", shots=3000).run(
        SamplerEngine(seed=5))
    for ej, sj, se in zip(exact.jacobians, sampled.jacobians, sampled.jacobian_errors,
                          strict=True):
        assert np.all(np.abs(sj - ej) <= 5 * se + 1e-9)
    assert np.all(np.abs(sampled.outputs - exact.outputs) <= 5 * sampled.output_errors + 1e-9)


def test_unary_kept_fraction_is_the_count_of_weight_one_shots():
    # 4000 shots over 32 unary outcomes with these counts: the 32 frequencies count / 4000 sum
    # to an ulp below 1 in floating point, but every shot has weight 1 (kept is 4000 / 4000)
    counts = np.array([200, 1085, 182, 177, 79, 15, 29, 30, 10, 6, 0, 35, 69, 3, 19, 35, 0, 6,
                       58, 6, 0, 6, 170, 105, 715, 352, 3, 15, 4, 6, 460, 120])
    shots, m = int(counts.sum()), counts.size
    assert np.sum(counts / shots) != 1.0  # the case the rounding bites
    cols = np.random.default_rng(2).permutation(np.repeat(np.arange(m), counts))
    bits = np.zeros((1, shots, m), bool)
    bits[0, np.arange(shots), cols] = True
    p, kept = unary_frequencies(JobResult(None, shots, None, bits=bits))
    assert kept[0] == 1.0
    np.testing.assert_array_equal(np.rint(p[0] * shots), counts)
    bits[0, :7, (cols[:7] + 1) % m] = True  # 7 shots of weight 2 (none of them a repeat)
    p, kept = unary_frequencies(JobResult(None, shots, None, bits=bits))
    assert kept[0] == (shots - 7) / shots
    ones = np.ones((1, shots))  # unit weights: the same fraction
    _, kept_w = unary_frequencies(JobResult(None, shots, None, bits=bits, weights=ones,
                                            effective_shots=np.array([shots])))
    assert kept_w[0] == (shots - 7) / shots
