"""l-infinity tomography of unary states (Supp. F) against exact and sampled oracles."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import QuantumCircuit, transpile
from qiskit.circuit import ParameterVector
from qiskit.quantum_info import Statevector
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, ReadoutError
from qiskit_aer.primitives import SamplerV2

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.gates import RBSGate
from qdensity.circuits.tomography import (
    TomographyResult,
    bridge_circuit,
    bridge_pairs,
    reconstruct,
    shots_for_error,
    tomography_circuits,
)

BIG = 1e14  # synthetic "exact" shot total


# ----------------------------------------------------------------------------- oracles
def prep(y: np.ndarray) -> QuantumCircuit:
    """Prepare sum_j y_j |e_j> with Qiskit's generic StatePreparation (an independent oracle)."""
    n = len(y)
    psi = np.zeros(2**n)
    psi[[2**j for j in range(n)]] = y
    qc = QuantumCircuit(n, name="prep")
    qc.prepare_state(psi)
    return qc


def exact_counts(circuit: QuantumCircuit, total: float = BIG) -> dict:
    """Counts proportional to the exact outcome distribution (bitstring keys)."""
    probs = Statevector(circuit.remove_final_measurements(inplace=False)).probabilities_dict()
    return {str(k): total * float(p) for k, p in probs.items()}


def linf_up_to_sign(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(min(np.abs(estimate - truth).max(), np.abs(estimate + truth).max()))


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def gap_free_vector(rng: np.random.Generator, n: int, floor: float = 0.15) -> np.ndarray:
    """Random signed unit vector, |y_j| >= floor inside, maybe a zero at an end (no gap)."""
    while True:
        y = rng.normal(size=n)
        if rng.random() < 0.5:
            y[0 if rng.random() < 0.5 else n - 1] = 0.0
        y = unit(y)
        inner = np.abs(y[np.abs(y) > 0])
        if inner.min() >= floor:
            return y


# ----------------------------------------------------------------------------- circuits
def test_circuits_structure_and_transpile():
    qc = pyramid(5)
    circuits = tomography_circuits(qc)
    assert len(circuits) == 3
    expected_rbs = [10, 12, 12]
    for circuit, count in zip(circuits, expected_rbs, strict=True):
        assert circuit.count_ops()["rbs"] == count
        assert circuit.count_ops()["measure"] == 5
        assert circuit.parameters == qc.parameters  # stays parameterised, same order
        assert [r.name for r in circuit.cregs] == ["meas"]
        for inst in circuit.data:
            if inst.operation.name == "measure":
                q = circuit.find_bit(inst.qubits[0]).index
                c = circuit.find_bit(inst.clbits[0]).index
                assert q == c
        for basis in (["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"]):
            transpile(circuit, basis_gates=basis, optimization_level=1)
    bridge = bridge_circuit(qc, [(0, 3), (4, 1)])
    assert bridge.count_ops()["rbs"] == 12
    transpile(bridge, basis_gates=["cz", "rz", "sx", "x"], optimization_level=1)


def test_sign_circuit_probabilities_match_formula():
    """Circuit 1 / 2 probabilities are ((y_a -+ y_b)^2 / 2) on each rotated pair."""
    y = unit([0.3, -0.5, 0.2, 0.6, -0.4])
    circuits = tomography_circuits(prep(y))
    p = [exact_counts(c, 1.0) for c in circuits]

    def unary(d, j):
        return d.get(format(2**j, "05b"), 0.0)

    for j in range(5):
        assert unary(p[0], j) == pytest.approx(y[j] ** 2, abs=1e-12)
    for c, start in ((1, 0), (2, 1)):
        expected = y**2
        for a in range(start, 4, 2):
            expected = expected.copy()
            expected[a] = (y[a] - y[a + 1]) ** 2 / 2
            expected[a + 1] = (y[a] + y[a + 1]) ** 2 / 2
        for j in range(5):
            assert unary(p[c], j) == pytest.approx(expected[j], abs=1e-12)


# ----------------------------------------------------------------------------- exact counts
@settings(max_examples=15, deadline=None)
@given(n=st.integers(2, 6), seed=st.integers(0, 2**32 - 1))
def test_exact_counts_reconstruct_exact_vector(n, seed):
    rng = np.random.default_rng(seed)
    y = gap_free_vector(rng, n)
    counts = [exact_counts(c) for c in tomography_circuits(prep(y))]
    res = reconstruct(counts, n)
    assert isinstance(res, TomographyResult)
    assert linf_up_to_sign(res.amplitudes, y) < 1e-6
    assert res.signs_resolved and len(res.components) == 1
    assert res.error_estimate < 1e-5
    assert res.kept_fraction == pytest.approx((1.0, 1.0, 1.0))
    np.testing.assert_allclose(res.magnitudes, np.abs(y), atol=1e-6)
    assert set(np.unique(res.signs)) <= {-1, 1}


def test_zero_in_the_middle_gives_two_components_and_bridge_joins_them():
    y = unit([0.5, -0.4, 0.0, 0.6, -0.3])
    qc = prep(y)
    counts = [exact_counts(c) for c in tomography_circuits(qc)]
    res = reconstruct(counts, 5)
    assert not res.signs_resolved
    assert sorted(res.components) == [(0, 1), (3, 4)]
    assert res.components[0] == (3, 4)  # the reference holds the largest amplitude
    assert 2 in res.negligible
    np.testing.assert_allclose(res.magnitudes, np.abs(y), atol=1e-6)
    # within each component the relative signs are right
    assert res.signs[0] * res.signs[1] == -1 and res.signs[3] * res.signs[4] == -1
    # the honest error estimate covers an undetermined relative sign
    assert res.error_estimate >= 2 * abs(y[0])
    assert res.error_estimate >= linf_up_to_sign(res.amplitudes, y)

    # explicit bridge across the gap
    extra = [([(1, 3)], exact_counts(bridge_circuit(qc, [(1, 3)])))]
    joined = reconstruct(counts, 5, extra=extra)
    assert joined.signs_resolved and joined.components == ((0, 1, 3, 4),)
    assert linf_up_to_sign(joined.amplitudes, y) < 1e-6
    assert joined.error_estimate < 1e-5

    # suggested bridges
    suggested = bridge_pairs(res)
    assert suggested == [[(0, 3)]]
    extra = [(pairs, exact_counts(bridge_circuit(qc, pairs))) for pairs in suggested]
    assert linf_up_to_sign(reconstruct(counts, 5, extra=extra).amplitudes, y) < 1e-6


def test_three_components_need_two_bridge_circuits():
    y = unit([0.5, 0.0, -0.6, 0.0, 0.4, 0.3])
    qc = prep(y)
    counts = [exact_counts(c) for c in tomography_circuits(qc)]
    res = reconstruct(counts, 6)
    assert sorted(res.components) == [(0,), (2,), (4, 5)]
    suggested = bridge_pairs(res)
    assert suggested == [[(0, 2)], [(2, 4)]]
    extra = [(pairs, exact_counts(bridge_circuit(qc, pairs))) for pairs in suggested]
    joined = reconstruct(counts, 6, extra=extra)
    assert joined.signs_resolved
    assert linf_up_to_sign(joined.amplitudes, y) < 1e-6


def test_postselection_discards_non_unary_outcomes_and_int_keys():
    y = unit([0.6, -0.2, 0.7, 0.3])
    counts = [exact_counts(c) for c in tomography_circuits(prep(y))]
    junk = {"0000": 0.1 * BIG, "0110": 0.05 * BIG, "1111": 0.05 * BIG}
    noisy = [{**c, **junk} for c in counts]
    res = reconstruct(noisy, 4)
    assert linf_up_to_sign(res.amplitudes, y) < 1e-6
    assert res.kept_fraction == pytest.approx((1 / 1.2,) * 3)
    assert res.shots == pytest.approx((1.2 * BIG,) * 3, rel=1e-12)
    raw = reconstruct(noisy, 4, postselect=False)
    assert raw.kept_fraction == (1.0, 1.0, 1.0)
    np.testing.assert_allclose(raw.magnitudes, np.abs(y) / np.sqrt(1.2), atol=1e-6)
    as_ints = [{int(k, 2): v for k, v in c.items()} for c in counts]
    assert linf_up_to_sign(reconstruct(as_ints, 4).amplitudes, y) < 1e-6


def test_tiny_amplitudes_take_sign_plus_one():
    y = unit([0.7, -0.7, 1e-9, 0.0])
    counts = [exact_counts(c) for c in tomography_circuits(prep(y))]
    res = reconstruct(counts, 4, delta=1e-4)
    assert res.components == ((0, 1),)
    assert res.signs[2] == 1 and res.signs[3] == 1
    assert linf_up_to_sign(res.amplitudes, y) < 1e-6


# ----------------------------------------------------------------------------- sampled
def _sample(circuits, shots, seed, noise_model=None, parameter_values=None):
    options = {"backend_options": {"noise_model": noise_model}} if noise_model else None
    sampler = SamplerV2(seed=seed, options=options)
    pubs = [(c,) if parameter_values is None else (c, parameter_values) for c in circuits]
    result = sampler.run(pubs, shots=shots).result()
    return [r.data.meas.get_counts() for r in result]


def chain_loader(n: int) -> QuantumCircuit:
    """X on qubit 0, then RBS(x_k) on (k, k + 1): a parameterised unary loader (data in "x")."""
    x = ParameterVector("x", n - 1)
    qc = QuantumCircuit(n, name="chain")
    qc.x(0)
    for k in range(n - 1):
        qc.append(RBSGate(x[k]), [k, k + 1])
    return qc


def chain_angles(y: np.ndarray) -> np.ndarray:
    tails = np.sqrt(np.cumsum((y**2)[::-1])[::-1])
    angles = np.arctan2(tails[1:], y[:-1])
    angles[-1] = np.arctan2(y[-1], y[-2])
    return angles


def test_sampled_error_within_shots_for_error():
    n, delta, p_fail, trials = 5, 0.2, 0.01, 20
    shots = shots_for_error(delta, n, p_fail)
    rng = np.random.default_rng(2024)
    loader = chain_loader(n)
    rows = []
    truths = []
    for _ in range(trials):
        angles = chain_angles(gap_free_vector(rng, n))
        rows.append(angles)
        bound = Statevector(loader.assign_parameters(angles)).data
        truths.append(bound[[2**j for j in range(n)]].real)  # oracle: exact statevector
    circuits = transpile(tomography_circuits(loader), AerSimulator(), seed_transpiler=1)
    # one PUB per circuit, one parameter row per trial
    result = SamplerV2(seed=7).run([(c, np.array(rows)) for c in circuits], shots=shots).result()
    failures = unresolved = misestimated = 0
    for t, y in enumerate(truths):
        assert np.abs(y[np.abs(y) > 1e-12]).min() >= 0.15 - 1e-9  # gap-free truth
        counts = [r.data.meas.get_counts(t) for r in result]
        res = reconstruct(counts, n, p_fail=p_fail)
        assert res.shots == (shots, shots, shots)
        error = linf_up_to_sign(res.amplitudes, y)
        failures += error > delta
        unresolved += not res.signs_resolved
        misestimated += error > res.error_estimate
    # each event has probability <= p_fail = 0.01 per trial: 2 of 20 would be very unlikely
    assert failures <= 1
    assert unresolved <= 1
    assert misestimated <= 1


def test_sampled_parameterised_circuit_one_pub_per_circuit():
    n = 4
    rng = np.random.default_rng(5)
    x = unit(rng.uniform(0.3, 1.0, n))
    qc = prep(x).compose(pyramid(n))
    values = rng.uniform(-np.pi, np.pi, qc.num_parameters)
    truth = Statevector(qc.assign_parameters(values)).data[[2**j for j in range(n)]].real
    circuits = transpile(tomography_circuits(qc), AerSimulator(), seed_transpiler=1)
    assert all(c.num_parameters == qc.num_parameters for c in circuits)
    shots = shots_for_error(0.15, n, 0.01)
    res = reconstruct(_sample(circuits, shots, 11, parameter_values=values), n)
    assert linf_up_to_sign(res.amplitudes, truth) <= max(0.15, res.error_estimate)
    assert linf_up_to_sign(res.amplitudes, truth) <= res.error_estimate


def test_bit_arrays_are_accepted_one_row_at_a_time():
    n = 3
    y = unit([0.6, -0.6, 0.5])
    circuits = transpile(tomography_circuits(prep(y)), AerSimulator(), seed_transpiler=1)
    result = SamplerV2(seed=1).run([(c,) for c in circuits], shots=20_000).result()
    res = reconstruct([r.data.meas for r in result], n)
    assert linf_up_to_sign(res.amplitudes, y) <= res.error_estimate
    loader = chain_loader(n)
    circuits = transpile(tomography_circuits(loader), AerSimulator(), seed_transpiler=1)
    rows = np.array([chain_angles(y), chain_angles(unit([1.0, 1.0, 1.0]))])
    result = SamplerV2(seed=1).run([(c, rows) for c in circuits], shots=100).result()
    with pytest.raises(ValueError, match="2 parameter rows"):
        reconstruct([r.data.meas for r in result], n)
    with pytest.raises(ValueError, match="3 bits per shot but num_qubits is 4"):
        reconstruct([r.data.meas for r in result], 4)


def test_postselection_with_readout_noise():
    n = 4
    y = unit([0.5, -0.6, 0.4, 0.5])
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[0.97, 0.03], [0.03, 0.97]]))
    circuits = transpile(tomography_circuits(prep(y)), AerSimulator(), seed_transpiler=1)
    counts = _sample(circuits, 40_000, 3, noise_model=noise)
    res = reconstruct(counts, n)
    assert all(0.8 < k < 0.95 for k in res.kept_fraction)  # about 0.97**4 + O(eps^2)
    assert linf_up_to_sign(res.amplitudes, y) < 0.05
    assert res.signs_resolved
    assert np.sum(res.magnitudes**2) == pytest.approx(1.0)
    raw = reconstruct(counts, n, postselect=False)
    assert raw.kept_fraction == (1.0, 1.0, 1.0)
    assert np.sum(raw.magnitudes**2) == pytest.approx(res.kept_fraction[0])


# ----------------------------------------------------------------------------- shots_for_error
def test_shots_for_error_scaling():
    base = shots_for_error(0.2, 8, 0.01)
    assert shots_for_error(0.1, 8, 0.01) == pytest.approx(4 * base, rel=1e-3)
    assert shots_for_error(0.2, 64, 0.01) > base
    assert shots_for_error(0.2, 8, 0.001) > base
    # O(log n): 8x more qubits costs far less than 8x more shots
    assert shots_for_error(0.2, 64, 0.01) < 1.5 * base


# ----------------------------------------------------------------------------- bad input
def _ok_counts(n=3):
    return [{"001": 10, "010": 10}, {"001": 10, "100": 10}, {"010": 10, "100": 10}]


def test_bad_counts():
    with pytest.raises(ValueError, match="exactly 3"):
        reconstruct(_ok_counts()[:2], 3)
    with pytest.raises(TypeError, match="counts must be a list of the three circuits"):
        reconstruct(_ok_counts()[0], 3)
    with pytest.raises(TypeError, match=r"counts\[1\]"):
        reconstruct([_ok_counts()[0], [1, 2], _ok_counts()[2]], 3)
    bad = _ok_counts()
    bad[1] = {"0001": 5, "0010": 5}
    with pytest.raises(ValueError, match=r"counts\[1\] key '0001'.*3-bit"):
        reconstruct(bad, 3)
    bad = _ok_counts()
    bad[2] = {1: 5, 8: 5}
    with pytest.raises(ValueError, match=r"counts\[2\] key 8 is outside"):
        reconstruct(bad, 3)
    bad = _ok_counts()
    bad[0] = {"001": -1, "010": 5}
    with pytest.raises(ValueError, match=r"counts\[0\]\['001'\].*non-negative"):
        reconstruct(bad, 3)
    bad = _ok_counts()
    bad[0] = {"001": 0}
    with pytest.raises(ValueError, match=r"counts\[0\] has zero total shots"):
        reconstruct(bad, 3)
    bad = _ok_counts()
    bad[1] = {"011": 7}
    with pytest.raises(ValueError, match=r"counts\[1\] has no Hamming-weight-1"):
        reconstruct(bad, 3)
    with pytest.raises(ValueError, match="num_qubits"):
        reconstruct(_ok_counts(), 1)
    with pytest.raises(ValueError, match="p_fail"):
        reconstruct(_ok_counts(), 3, p_fail=1.5)
    with pytest.raises(ValueError, match="delta"):
        reconstruct(_ok_counts(), 3, delta=-0.1)
    with pytest.raises(ValueError, match="disjoint"):
        reconstruct(_ok_counts(), 3, extra=[([(0, 1), (1, 2)], {"001": 1})])
    with pytest.raises(ValueError, match=r"extra\[0\]"):
        reconstruct(_ok_counts(), 3, extra=[([(0, 2)],)])


def test_bad_circuits_and_pairs():
    qc = QuantumCircuit(3, 1)
    with pytest.raises(ValueError, match="classical bits"):
        tomography_circuits(qc)
    with pytest.raises(ValueError, match=">= 2 qubits"):
        tomography_circuits(QuantumCircuit(1))
    with pytest.raises(TypeError, match="circuit"):
        tomography_circuits("pyramid")
    with pytest.raises(ValueError, match="out of range"):
        bridge_circuit(pyramid(3), [(0, 3)])
    with pytest.raises(ValueError, match="itself"):
        bridge_circuit(pyramid(3), [(1, 1)])
    with pytest.raises(ValueError, match="disjoint"):
        bridge_circuit(pyramid(4), [(0, 2), (2, 3)])
    with pytest.raises(ValueError, match="at least one"):
        bridge_circuit(pyramid(4), [])


def test_bad_shots_for_error_arguments():
    with pytest.raises(ValueError, match="delta"):
        shots_for_error(0.0, 4, 0.01)
    with pytest.raises(ValueError, match="num_qubits"):
        shots_for_error(0.1, 1, 0.01)
    with pytest.raises(ValueError, match="p_fail"):
        shots_for_error(0.1, 4, 0.0)
    with pytest.raises(TypeError, match="num_qubits"):
        shots_for_error(0.1, 4.0, 0.01)
