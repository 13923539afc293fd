"""Exact noisy distributions (:mod:`qdensity.execution.samplers.noisy_exact`) against Aer.

Oracles: Aer's ``density_matrix`` method run on each bound circuit with its final
measurements replaced by ``save_probabilities`` (the exact pre-readout distribution, to 1e-10),
the readout errors then applied as the confusion matrices ``P[true, read]``; and, for the
drawn shots, a chi-square goodness-of-fit test at a stated false-failure rate.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector
from qiskit.primitives.containers import SamplerPub
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, ReadoutError, depolarizing_error, pauli_error
from scipy import stats

from qdensity.execution.samplers.noisy_exact import (
    ExactNoisySampler,
    ExactRoute,
    exact_from,
    exact_probabilities,
    supported,
)
from qdensity.hardware.targets import get_target


def _circuit(n=4):
    th = ParameterVector("t", 5)
    qc = QuantumCircuit(n)
    qc.ry(th[0], 0)
    qc.cx(0, 1)
    qc.rz(2 * th[1] + 0.3, 1)
    qc.cx(1, 2)
    qc.rx(th[2], 3)
    qc.cx(3, 2)
    qc.ry(th[3], 2)
    qc.cx(2, 0)
    qc.h(3)
    qc.rzz(th[4], 1, 3)
    qc.measure_all()
    return qc


def _aer_probabilities(circuit, values, noise):
    """Exact probabilities of the measured clbits (clbit order, bit i of the index = clbit
    i): Aer's density matrix before the measurements, then each readout matrix (a model
    without quantum errors on ``measure``: those act only on measure instructions)."""
    meas = sorted(((circuit.find_bit(i.qubits[0]).index, circuit.find_bit(i.clbits[0]).index)
                   for i in circuit.data if i.name == "measure"), key=lambda x: x[1])
    bound = circuit.assign_parameters(values).remove_final_measurements(inplace=False)
    bound.save_probabilities([q for q, _ in meas])
    sim = AerSimulator(method="density_matrix", noise_model=noise)
    probs = np.asarray(sim.run(bound).result().data()["probabilities"])
    m = len(meas)
    arr = probs.reshape([2] * m)  # axes: bit m-1 ... bit 0
    readout = {}
    for e in (noise.to_dict()["errors"] if noise is not None else []):
        if e["type"] == "roerror":
            for g in e["gate_qubits"]:
                readout[g[0]] = np.asarray(e["probabilities"])
    for i, (q, _) in enumerate(meas):
        if q in readout:
            ax = m - 1 - i
            arr = np.moveaxis(np.tensordot(arr, readout[q], axes=([ax], [0])), -1, ax)
    return arr.ravel()


@pytest.fixture(scope="module")
def device():
    return get_target("heavy_hex", 6, seed=7)


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_probabilities_equal_aer_density_matrix_on_a_noisy_device(device, kernel, monkeypatch):
    """Both block kernels (numba's, and numpy's used with ``QDENSITY_NUMBA=0``)."""

    if kernel == "numpy":
        monkeypatch.setenv("QDENSITY_NUMBA", "0")
    tc = device.transpile(_circuit())
    sampler = ExactNoisySampler(device.noise_model, seed=1)
    values = np.random.default_rng(0).uniform(-3, 3, size=(3, tc.num_parameters))
    got = exact_probabilities(sampler.program(tc), values)
    for r in range(3):
        np.testing.assert_allclose(got[r], _aer_probabilities(tc, values[r], device.noise_model),
                                   atol=1e-10)


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_rows_sharing_leading_parameters_equal_aer_row_by_row(device, kernel, monkeypatch):
    """A parameter-shift PUB: rows equal to a base row but for one parameter (each of them
    shifted by +-pi/2), repeated rows and a second base row. Rows that agree so far share one
    density matrix inside; every row must still equal Aer's density matrix of that row."""
    if kernel == "numpy":
        monkeypatch.setenv("QDENSITY_NUMBA", "0")
    tc = device.transpile(_circuit())
    P = tc.num_parameters
    rng = np.random.default_rng(4)
    rows = []
    for base in rng.uniform(-3, 3, size=(2, P)):
        rows.append(base)
        for j in range(P):
            for shift in (np.pi / 2, -np.pi / 2):
                row = base.copy()
                row[j] += shift
                rows.append(row)
    rows.append(rows[3].copy())  # a repeated row
    values = np.array(rows)
    got = exact_probabilities(ExactNoisySampler(device.noise_model).program(tc), values)
    assert got.shape == (len(rows), 2**4)
    for r in range(0, len(rows), 3):  # every third row against Aer (the oracle costs)
        np.testing.assert_allclose(got[r], _aer_probabilities(tc, values[r], device.noise_model),
                                   atol=1e-10)
    np.testing.assert_array_equal(got[-1], got[3])


def test_a_sampler_made_after_a_new_instruction_reads_its_error():
    noise = NoiseModel()
    noise.add_all_qubit_quantum_error(depolarizing_error(0.1, 1), ["x"])
    a = ExactNoisySampler(noise)
    assert a.tables.error("sx", (0,)) is None
    noise.add_quantum_error(depolarizing_error(0.2, 1), ["sx"], [0])  # new instruction
    assert ExactNoisySampler(noise).tables.error("sx", (0,)) is not None


def test_local_errors_replace_all_qubit_errors_and_measure_errors_act_first():
    """A qubit-specific error on ``x`` replaces the all-qubit one (qubit 0: identity, qubit 1:
    a flip), and an error on ``measure`` acts before the measurement, as in Aer."""
    noise = NoiseModel()
    noise.add_all_qubit_quantum_error(pauli_error([("X", 0.3), ("I", 0.7)]), ["x"])
    noise.add_quantum_error(depolarizing_error(0.1, 1), ["x"], [0])
    noise.add_quantum_error(pauli_error([("X", 0.2), ("I", 0.8)]), ["measure"], [1])
    noise.add_readout_error(ReadoutError([[0.9, 0.1], [0.25, 0.75]]), [0])
    qc = QuantumCircuit(2)
    qc.x(0)
    qc.x(1)
    qc.measure_all()
    got = exact_probabilities(ExactNoisySampler(noise).program(qc), np.zeros((1, 0)))[0]
    # by hand: qubit 0 flipped with depolarising p = 0.1 (stays 0 with prob 0.05), then read
    # through its matrix; qubit 1 flipped by X with 0.3 after x, then 0.2 before measure
    q0 = np.array([0.05, 0.95]) @ np.array([[0.9, 0.1], [0.25, 0.75]])
    one = 0.7 * 0.8 + 0.3 * 0.2
    q1 = np.array([1 - one, one])
    np.testing.assert_allclose(got, np.kron(q1, q0), atol=1e-12)
    # and Aer's own shots (density matrix, 40,000): a chi-square test at the 0.1% level
    counts = AerSimulator(method="density_matrix", noise_model=noise, seed_simulator=3).run(
        qc, shots=40_000).result().get_counts()
    observed = [counts.get(k, 0) for k in ("00", "01", "10", "11")]
    assert stats.chisquare(observed, got * 40_000).pvalue > 1e-3


def test_drawn_counts_follow_the_exact_distribution(device):
    """Chi-square goodness of fit of 20,000 shots per row, 3 rows, each at the 0.1% level:
    false-failure rate about 0.3% (cells of expected count < 5 merged)."""
    tc = device.transpile(_circuit())
    sampler = ExactNoisySampler(device.noise_model, seed=11)
    values = np.random.default_rng(2).uniform(-3, 3, size=(3, tc.num_parameters))
    exact = exact_probabilities(sampler.program(tc), values)
    res = sampler.run([(tc, values, 20_000)]).result()[0]
    assert res.data.meas.shape == (3,) and res.data.meas.num_shots == 20_000
    for r in range(3):
        counts = res.data.meas.get_int_counts(r)
        observed = np.zeros(exact.shape[1])
        for k, v in counts.items():
            observed[k] = v
        expected = exact[r] * 20_000
        big = expected >= 5
        obs = np.append(observed[big], observed[~big].sum())
        exp = np.append(expected[big], expected[~big].sum())
        if exp[-1] == 0:
            obs, exp = obs[:-1], exp[:-1]
        assert stats.chisquare(obs, exp).pvalue > 1e-3


def test_same_seed_same_shots_another_seed_others():
    qc = _circuit()
    values = np.full((2, qc.num_parameters), 0.4)
    a, b = ExactNoisySampler(None, seed=5), ExactNoisySampler(None, seed=5)
    first = a.run([(qc, values, 50)]).result()[0].data.meas.array
    assert np.array_equal(first, b.run([(qc, values, 50)]).result()[0].data.meas.array)
    assert np.array_equal(first, a.run([(qc, values, 50)]).result()[0].data.meas.array)
    other = ExactNoisySampler(None, seed=6).run([(qc, values, 50)]).result()[0].data.meas.array
    assert not np.array_equal(first, other)
    copy = pickle.loads(pickle.dumps(a))  # compiled programs (weak references) not pickled
    copy.run([(qc, values, 5)]).result()


def test_the_same_circuit_gets_the_same_shots_whatever_its_name():
    # Qiskit names an unnamed circuit by how many were made before it ("circuit-46"), so a
    # stream keyed by the name changed with what a process (or a test order) had run first.
    values = np.full((3, 5), 0.7)
    one, two = _circuit(), _circuit()
    two.name = "renamed"
    shots = [ExactNoisySampler(None, seed=5).run([(c, values, 40)]).result()[0].data.meas.array
             for c in (one, two)]
    assert one.name != two.name and np.array_equal(shots[0], shots[1])
    # another circuit (its Hadamard on qubit 2 instead of 3) draws another stream
    three = _circuit()
    assert three.data[8].operation.name == "h"
    three.data[8] = three.data[8].replace(qubits=(three.qubits[2],))
    other = ExactNoisySampler(None, seed=5).run([(three, values, 40)]).result()[0].data.meas.array
    assert not np.array_equal(shots[0], other)


def test_unsupported_circuits_are_refused_before_any_work():
    sampler = ExactNoisySampler(None)
    mid = QuantumCircuit(2, 2)
    mid.h(0)
    mid.measure(0, 0)
    mid.x(0)
    mid.measure(1, 1)
    reset = QuantumCircuit(1, 1)
    reset.reset(0)
    reset.measure(0, 0)
    for qc in (mid, reset):
        assert not supported(qc, sampler.tables)
        with pytest.raises(ValueError, match="pubs\\[0\\]"):
            sampler.run([qc])
    with pytest.raises(TypeError, match="noise_model"):
        ExactNoisySampler("noise")
    with pytest.raises((TypeError, ValueError), match="default_shots"):
        ExactNoisySampler(None, default_shots=0)
    with pytest.raises((TypeError, ValueError), match="num_active"):
        exact_from(-1)


def test_route_takes_only_few_qubit_noisy_pubs_above_the_crossover(device):
    assert [exact_from(a) for a in (4, 6, 8, 10)] == [2, 5, 20, 80]
    tc = device.transpile(_circuit())
    pubs = [SamplerPub.coerce((tc, np.zeros(tc.num_parameters), s)) for s in (1, 16)]
    route = ExactRoute(lambda method: device.simulator(method=method, seed=1), noisy=True)
    out = [None, None]
    assert route.take(pubs, out, seed=3, overrides={}) == {1}
    assert out[0] is None and out[1].data.meas.num_shots == 16
    assert route.take(pubs, [None, None], 3, {"method": "statevector"}) == set()
    assert ExactRoute(lambda m: None, noisy=False).take(pubs, [None, None], 3, {}) == set()


def test_a_sampler_made_after_the_noise_model_changed_reads_the_new_noise():
    """Errors added to an instruction the model already had are seen by the next sampler.

    Oracle: X then depolarizing p = 0.1 then (appended) p = 0.5 gives P(0) = 0.5 * 0.05 + 0.25
    = 0.275; 20,000 shots, bound 5 binomial standard errors (false failure about 6e-7)."""
    from qiskit_aer.noise import NoiseModel, depolarizing_error

    from qdensity.execution.samplers import ExactNoisySampler

    qc = QuantumCircuit(1)
    qc.x(0)
    qc.measure_all()
    model = NoiseModel(basis_gates=["x", "sx", "rz"])
    model.add_quantum_error(depolarizing_error(0.1, 1), ["x"], [0])
    first = ExactNoisySampler(model, seed=1).run([qc], shots=20_000).result()[0]
    p0 = first.data.meas.get_counts().get("0", 0) / 20_000
    assert abs(p0 - 0.05) < 5 * (0.05 * 0.95 / 20_000) ** 0.5
    model.add_quantum_error(depolarizing_error(0.5, 1), ["x"], [0])  # appended to the same error
    second = ExactNoisySampler(model, seed=1).run([qc], shots=20_000).result()[0]
    p0 = second.data.meas.get_counts().get("0", 0) / 20_000
    assert abs(p0 - 0.275) < 5 * (0.275 * 0.725 / 20_000) ** 0.5
