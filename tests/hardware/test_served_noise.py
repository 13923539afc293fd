"""A target's simulator serves Aer only the noise of the active qubits: the same channel as the
whole model (exact density-matrix probabilities, and identical counts for a seed)."""

from __future__ import annotations

import pickle

import numpy as np
import qiskit_aer  # noqa: F401  (registers save_probabilities)
from qiskit import QuantumCircuit
from qiskit_aer import AerSimulator

from qdensity.hardware._mps_line import line_order, relabelled, renumbered
from qdensity.hardware._served_noise import (
    _SERVED,
    ServedModel,
    ServedNoiseSimulator,
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
    assert {len(q) for q in served_sets} == {3, 4}  # two qubit sets served, each its own errors
    assert all(isinstance(m, ServedModel) for m in served_sets.values())


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


def test_mps_line_relabelling_keeps_the_channel():
    # a GHZ chain laid out on fake_kolkata's scattered qubits, relabelled onto Aer's line with
    # its noise renumbered: the same density-matrix probabilities as the device's whole model
    tgt = get_target("fake_kolkata", seed=1)
    qc = QuantumCircuit(5, 5)
    qc.h(0)
    for q in range(4):
        qc.cx(q, q + 1)
    qc.measure(range(5), range(5))
    circuit = tgt.transpile(qc)
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
