"""A target's simulator serves Aer only the noise of the active qubits, on public API: the same
channel as the whole model (exact density-matrix probabilities; identical counts for a seed
with statevector and density matrix, the law of the counts with matrix-product states, whose
circuits go on a line)."""

from __future__ import annotations

import pickle
from copy import deepcopy

import numpy as np
import qiskit_aer  # noqa: F401  (registers save_probabilities)
from _stats import stat_seed
from qiskit import QuantumCircuit
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, QuantumError, pauli_error
from scipy.stats import chi2

from qdensity.hardware._mps_line import line_order, relabelled, renumbered
from qdensity.hardware._served_noise import (
    _SERVED,
    ServedModel,
    ServedNoiseSimulator,
    _served,
    restricted_errors,
    served_model,
)
from qdensity.hardware.targets import get_target


def _chain(n: int, first: int, width: int) -> QuantumCircuit:
    """A noisy chain on qubits first .. first + n - 1 of a ``width``-qubit register."""
    qc = QuantumCircuit(width, n)
    qs = list(range(first, first + n))
    qc.sx(qs[0])
    qc.rz(0.7, qs[0])
    for a, b in zip(qs, qs[1:], strict=False):
        qc.cx(a, b)
        qc.sx(b)
    qc.measure(qs, range(n))
    return qc


def _probabilities(sim: AerSimulator, circuit: QuantumCircuit) -> np.ndarray:
    measured = [circuit.find_bit(i.qubits[0]).index for i in circuit.data
                if i.operation.name == "measure"]
    qc = circuit.remove_final_measurements(inplace=False)
    qc.save_probabilities(measured)
    return np.asarray(sim.run(qc).result().data()["probabilities"])


def test_density_matrix_of_active_qubits_equals_the_whole_model():
    # oracle: Aer's density matrix with the device's whole noise model, on the same circuits;
    # two qubit sets in turn on one simulator (each served its own errors)
    tgt = get_target("fake_kolkata", seed=1)
    assert tgt.num_qubits == 27
    full = AerSimulator.from_backend(tgt.backend, method="density_matrix",
                                     noise_model=tgt.noise_model)
    served = tgt.simulator(method="density_matrix")
    assert isinstance(served, ServedNoiseSimulator)
    for circuit in (_chain(3, 0, 27), _chain(4, 12, 27), _chain(3, 0, 27)):
        p, q = _probabilities(full, circuit), _probabilities(served, circuit)
        assert q.shape == (2**circuit.num_clbits,)
        np.testing.assert_allclose(q, p, atol=1e-12)
        assert 1 - p.max() > 1e-3  # the errors are there
    served_sets = _SERVED[id(tgt.noise_model)][2]
    for qubits in (frozenset(range(3)), frozenset(range(12, 16))):  # each its own errors
        assert isinstance(served_sets[qubits], ServedModel)


def test_counts_for_a_seed_equal_the_whole_model_with_readout_errors():
    tgt = get_target("heavy_hex", 4, seed=3)
    circuit = _chain(4, 0, tgt.num_qubits)
    for method in ("statevector", "density_matrix"):
        served = tgt.simulator(method=method, seed=5)
        full = AerSimulator.from_backend(tgt.backend, method=method,
                                         seed_simulator=served.options.seed_simulator,
                                         noise_model=tgt.noise_model)
        a = full.run(circuit, shots=500).result().get_counts()
        b = served.run(circuit, shots=500).result().get_counts()
        assert a == b
    assert sum(v for k, v in b.items() if k not in ("0000", "1111")) > 0  # noisy outcomes


def test_restriction_keeps_all_qubit_errors_and_those_inside():
    serialised = {"errors": [{"id": "all"}, {"id": "a", "gate_qubits": [[0, 1]]},
                             {"id": "b", "gate_qubits": [[1, 5]]},
                             {"id": "c", "gate_qubits": [[7], [1]]}]}
    kept = restricted_errors(serialised, frozenset({0, 1, 2}))["errors"]
    assert [e["id"] for e in kept] == ["all", "a", "c"]


def test_one_serialisation_per_model_shared_by_simulators_and_pickles():
    tgt = get_target("heavy_hex", 4, seed=3)
    circuit = _chain(3, 0, tgt.num_qubits)
    a, b = tgt.simulator(method="statevector", seed=5), tgt.simulator(method="density_matrix")
    before = a.run(circuit, shots=200).result().get_counts()
    whole = _SERVED[id(tgt.noise_model)][1]
    b.run(circuit, shots=10).result()
    assert _SERVED[id(tgt.noise_model)][1] is whole
    copy = pickle.loads(pickle.dumps(a))  # a fresh noise model object: serialised anew
    assert copy.options.noise_model is not tgt.noise_model
    assert copy.run(circuit, shots=200).result().get_counts() == before


def _ghz_chain_on_kolkata():
    """fake_kolkata's target and a 5-qubit GHZ chain transpiled for it (scattered qubits)."""
    tgt = get_target("fake_kolkata", seed=1)
    qc = QuantumCircuit(5, 5)
    qc.h(0)
    for q in range(4):
        qc.cx(q, q + 1)
    qc.measure(range(5), range(5))
    return tgt, tgt.transpile(qc)


def test_mps_line_relabelling_keeps_the_channel():
    # a GHZ chain laid out on fake_kolkata's scattered qubits, relabelled onto Aer's line with
    # its noise renumbered: the same density-matrix probabilities as the device's whole model
    tgt, circuit = _ghz_chain_on_kolkata()
    qubits = frozenset(circuit.find_bit(q).index for i in circuit.data
                       if i.operation.name != "barrier" for q in i.qubits)
    position = line_order([circuit], qubits)
    assert sorted(position.values()) == list(range(len(qubits)))
    moved = relabelled(circuit, position)
    assert moved.num_qubits == len(qubits) and moved.num_clbits == circuit.num_clbits
    far = max(abs(position[circuit.find_bit(a).index] - position[circuit.find_bit(b).index])
              for i in circuit.data if len(i.qubits) == 2 for a, b in [i.qubits])
    assert far == 1  # a chain on the line
    errors = renumbered(restricted_errors(tgt.noise_model.to_dict(), qubits), position)
    model = served_model(errors, tgt.noise_model.basis_gates)
    assert model is not None
    full = AerSimulator.from_backend(tgt.backend, method="density_matrix",
                                     noise_model=tgt.noise_model)
    given = AerSimulator(method="density_matrix", noise_model=model)
    p, q = _probabilities(full, circuit), _probabilities(given, moved)
    np.testing.assert_allclose(q, p, atol=1e-12)
    assert 1 - p[0] - p[-1] > 1e-3  # noisy


def _without_ids(errors: list) -> list:
    return [{k: v for k, v in e.items() if k != "id"} for e in errors]


def _assert_same_errors(got: list, want: list) -> None:
    # oracle: Aer's own serialisation of the device model; the same entries in the same order,
    # probabilities to 1e-12 relative (QuantumError renormalises them when rebuilt)
    got, want = _without_ids(got), _without_ids(want)
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert {k: v for k, v in g.items() if k != "probabilities"} == \
            {k: v for k, v in w.items() if k != "probabilities"}
        np.testing.assert_allclose(g["probabilities"], w["probabilities"], rtol=1e-12, atol=0)


def test_served_model_holds_the_device_errors_of_the_qubits():
    tgt = get_target("fake_kolkata", seed=1)
    whole = tgt.noise_model.to_dict(serializable=True)
    qubits = frozenset({0, 1, 2, 3, 5, 8})
    model = _served(tgt.noise_model, qubits)
    assert isinstance(model, ServedModel)
    want = restricted_errors(whole, qubits)["errors"]
    assert 0 < len(want) < len(whole["errors"])
    _assert_same_errors(model.to_dict(serializable=True)["errors"], want)
    # renumbered onto a line: the same errors on the new positions
    position = {0: 5, 1: 4, 2: 3, 3: 2, 5: 1, 8: 0}
    moved = _served(tgt.noise_model, qubits, position)
    _assert_same_errors(moved.to_dict(serializable=True)["errors"],
                        renumbered(restricted_errors(whole, qubits), position)["errors"])


def test_served_model_keeps_its_serialisation_until_changed():
    tgt = get_target("heavy_hex", 4, seed=3)
    model = served_model(restricted_errors(tgt.noise_model.to_dict(), frozenset({0, 1})),
                         tgt.noise_model.basis_gates)
    first = model.to_dict(serializable=True)
    assert model.to_dict(serializable=True) == first
    extra = pauli_error([("X", 0.25), ("I", 0.75)])
    copy = deepcopy(model)  # what Aer does before adding a circuit's own error instructions
    copy.add_all_qubit_quantum_error(extra, ["y"])
    assert model.to_dict(serializable=True) == first  # the original is untouched
    model.add_quantum_error(extra, ["y"], [1])
    for m in (model, copy):
        # oracle: NoiseModel's own serialisation (not kept) of the same model
        now = m.to_dict(serializable=True)
        assert now == NoiseModel.to_dict(m, serializable=True)
        assert len(now["errors"]) == len(first["errors"]) + 1


def test_an_error_it_cannot_rebuild_serves_the_whole_model():
    # a QuantumError holding an H gate: QuantumError.from_dict cannot read it back
    flip = QuantumCircuit(1)
    flip.h(0)
    model = NoiseModel()
    model.add_quantum_error(QuantumError([(flip, 0.2), (QuantumCircuit(1), 0.8)]), ["sx"], [0])
    model.add_quantum_error(pauli_error([("X", 0.1), ("I", 0.9)]), ["sx"], [1])
    assert served_model(model.to_dict(), model.basis_gates) is None
    assert _served(model, frozenset({0, 1})) is model
    qc = QuantumCircuit(2, 2)
    qc.sx([0, 1])
    qc.measure([0, 1], [0, 1])
    full = AerSimulator(method="density_matrix", noise_model=model)
    served = ServedNoiseSimulator(method="density_matrix", noise_model=model)
    np.testing.assert_allclose(_probabilities(served, qc), _probabilities(full, qc), atol=1e-12)


def test_delays_and_error_instructions_keep_the_whole_models_channel():
    # oracle: Aer's density matrix with the device's whole model. A delay is relaxed by the
    # model's noise pass (not in to_dict: the whole model is served); an error instruction in
    # the circuit is added by Aer to a copy of the served model
    tgt = get_target("fake_kolkata", seed=1)
    full = AerSimulator.from_backend(tgt.backend, method="density_matrix",
                                     noise_model=tgt.noise_model)
    served = tgt.simulator(method="density_matrix")
    waited = QuantumCircuit(27, 2)
    waited.x([3, 5])
    waited.delay(200, [3, 5], unit="us")
    waited.measure([3, 5], [0, 1])
    p = _probabilities(full, waited)
    np.testing.assert_allclose(_probabilities(served, waited), p, atol=1e-12)
    assert p[3] < 0.5  # relaxed over the delay (T1 ~ 100 us)
    flipped = QuantumCircuit(27, 3)
    flipped.sx(6)
    flipped.append(pauli_error([("X", 0.3), ("I", 0.7)]).to_instruction(), [7])
    flipped.cx(6, 7)
    flipped.cx(7, 8)
    flipped.measure([6, 7, 8], [0, 1, 2])
    served_set = frozenset({6, 7, 8})
    before = _served(tgt.noise_model, served_set).to_dict(serializable=True)
    np.testing.assert_allclose(_probabilities(served, flipped), _probabilities(full, flipped),
                               atol=1e-12)
    assert _served(tgt.noise_model, served_set).to_dict(serializable=True) == before


def test_the_run_options_noise_model_is_served():
    tgt = get_target("heavy_hex", 4, seed=3)
    circuit = _chain(3, 1, tgt.num_qubits)
    plain = AerSimulator(method="density_matrix")
    served = ServedNoiseSimulator(method="density_matrix")
    qc = circuit.remove_final_measurements(inplace=False)
    qc.save_probabilities([1, 2, 3])
    p = plain.run(qc, noise_model=tgt.noise_model).result().data()["probabilities"]
    q = served.run(qc, noise_model=tgt.noise_model).result().data()["probabilities"]
    np.testing.assert_allclose(q, p, atol=1e-12)
    assert frozenset({1, 2, 3}) in _SERVED[id(tgt.noise_model)][2]


def _with_readout(p: np.ndarray, measured: list[int], model: NoiseModel) -> np.ndarray:
    """``p`` (bit ``k`` from qubit ``measured[k]``) through the model's readout errors
    (``probabilities[true][read]`` per qubit)."""
    ro = {tuple(e["gate_qubits"][0]): np.asarray(e["probabilities"])
          for e in model.to_dict()["errors"] if e["type"] == "roerror"}
    n = len(measured)
    out = p.reshape((2,) * n)
    for k, q in enumerate(measured):  # bit k is axis n - 1 - k
        out = np.moveaxis(np.tensordot(ro[(q,)].T, out, axes=([1], [n - 1 - k])), 0, n - 1 - k)
    return out.reshape(-1)


def test_matrix_product_state_counts_follow_the_whole_models_law():
    # the line relabelling changes Aer's random stream, not the law: the served MPS simulator's
    # counts against the exact density-matrix probabilities of the device's whole model (its
    # readout errors applied), chi-square over outcomes (expected counts under 5 pooled),
    # false-failure rate 1e-4
    tgt, circuit = _ghz_chain_on_kolkata()
    full = AerSimulator.from_backend(tgt.backend, method="density_matrix",
                                     noise_model=tgt.noise_model)
    measured = [circuit.find_bit(i.qubits[0]).index for i in circuit.data
                if i.operation.name == "measure"]
    assert [circuit.find_bit(i.clbits[0]).index for i in circuit.data
            if i.operation.name == "measure"] == list(range(5))
    p = _with_readout(_probabilities(full, circuit), measured, tgt.noise_model)
    shots = 4000
    sim = tgt.simulator(method="matrix_product_state", seed=stat_seed(17))
    counts = sim.run(circuit, shots=shots).result().get_counts()
    observed = np.zeros(2**5)
    for key, v in counts.items():
        observed[int(key, 2)] = v
    expected = p * shots
    rare = expected < 5
    f_exp = np.append(expected[~rare], expected[rare].sum())
    f_obs = np.append(observed[~rare], observed[rare].sum())
    stat = float(((f_obs - f_exp) ** 2 / f_exp).sum())
    assert stat < chi2.ppf(1 - 1e-4, len(f_exp) - 1)
