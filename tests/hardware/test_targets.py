"""Hardware targets and noise models, against closed forms and exact operators."""

from __future__ import annotations

import math

import numpy as np
import pytest
import qiskit_aer  # noqa: F401  (registers save_density_matrix / set_density_matrix)
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector
from qiskit.circuit.library import XXPlusYYGate
from qiskit.providers.fake_provider import GenericBackendV2
from qiskit.quantum_info import Operator, Statevector
from qiskit.transpiler import CouplingMap
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel

import qdensity.hardware.targets as targets_mod
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.hardware.aer_sampling import aer_seed
from qdensity.hardware.noise import noise_from_backend, noise_model
from qdensity.hardware.targets import (
    RBS_NATIVE_BASIS,
    RBS_NATIVE_NOISE,
    HardwareTarget,
    get_target,
    gpu_available,
    heavy_hex_distance,
    known_targets,
)

# ----------------------------------------------------------------------------------------------
# independent oracles: channels written out by hand


def depolarize(rho: np.ndarray, lam: float) -> np.ndarray:
    """rho -> (1 - lam) rho + lam I / d on the whole register."""
    d = rho.shape[0]
    return (1 - lam) * rho + lam * np.trace(rho) * np.eye(d) / d


def apply_on_qubit(rho: np.ndarray, qubit: int, sup: np.ndarray) -> np.ndarray:
    """Apply a one-qubit map given as sup[a, b, c, d] (new[a, b] += sup * old[c, d])."""
    n = int(round(math.log2(rho.shape[0])))
    tens = rho.reshape([2] * (2 * n))
    row, col = n - 1 - qubit, 2 * n - 1 - qubit  # little-endian: qubit k is axis n-1-k
    tens = np.moveaxis(tens, (row, col), (0, 1))
    tens = np.einsum("abcd,cd...->ab...", sup, tens)
    tens = np.moveaxis(tens, (0, 1), (row, col))
    return tens.reshape(rho.shape)


def relax_qubit(rho: np.ndarray, qubit: int, t1: float, t2: float, t: float) -> np.ndarray:
    """Thermal relaxation (ground-state equilibrium) of one qubit of a register, closed form.

    [[r00 + (1-g1) r11, g2 r01], [g2 r10, g1 r11]], g1 = exp(-t/T1), g2 = exp(-t/T2).
    """
    g1, g2 = math.exp(-t / t1), math.exp(-t / t2)
    sup = np.zeros((2, 2, 2, 2))
    sup[0, 0, 0, 0] = 1.0
    sup[0, 0, 1, 1] = 1.0 - g1
    sup[1, 1, 1, 1] = g1
    sup[0, 1, 0, 1] = g2
    sup[1, 0, 1, 0] = g2
    return apply_on_qubit(rho, qubit, sup)


def depolarize_qubit(rho: np.ndarray, qubit: int, lam: float) -> np.ndarray:
    """rho -> (1 - lam) rho + lam Tr_q(rho) (x) I/2 on one qubit."""
    eye = np.eye(2)
    sup = (1 - lam) * np.einsum("ac,bd->abcd", eye, eye) + lam / 2 * np.einsum(
        "ab,cd->abcd", eye, eye)
    return apply_on_qubit(rho, qubit, sup)


def random_density(n: int, rng: np.random.Generator) -> np.ndarray:
    a = rng.normal(size=(2**n, 2**n)) + 1j * rng.normal(size=(2**n, 2**n))
    rho = a @ a.conj().T
    return rho / np.trace(rho)


def rbs(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=complex)


def noise_content(model: NoiseModel) -> list:
    """to_dict() without the random per-error ids, for comparing two models."""
    return [{k: v for k, v in err.items() if k != "id"}
            for err in model.to_dict(serializable=True)["errors"]]


def density_after(circuit: QuantumCircuit, model: NoiseModel | None) -> np.ndarray:
    sim = AerSimulator(method="density_matrix", noise_model=model)
    return np.asarray(sim.run(circuit).result().data()["density_matrix"])


# ----------------------------------------------------------------------------------------------
# catalogue and errors


def test_known_targets_lists_the_catalogue():
    assert set(known_targets()) >= {"ideal", "all_to_all", "line", "ring", "heavy_hex",
                                    "rbs_native"}


def test_unknown_target_message_lists_known_ones():
    with pytest.raises(ValueError) as info:
        get_target("grid", 4)
    for name in known_targets():
        assert name in str(info.value)
    assert "grid" in str(info.value)


@pytest.mark.parametrize(
    ("name", "n", "exc"),
    [("ideal", 0, ValueError), ("line", -2, ValueError), ("line", 1, ValueError),
     ("ring", 2, ValueError), ("rbs_native", 1, ValueError), ("ideal", True, TypeError),
     ("ideal", 2.0, TypeError)],
)
def test_bad_sizes_are_refused(name, n, exc):
    with pytest.raises(exc, match="num_qubits"):
        get_target(name, n)


def test_bad_basis_and_name_types():
    with pytest.raises(TypeError, match="name"):
        get_target(3, 2)
    with pytest.raises(ValueError, match="not_a_gate"):
        get_target("line", 3, basis_gates=["cz", "not_a_gate"])
    with pytest.raises(ValueError, match="rbs_native"):
        get_target("rbs_native", 3, basis_gates=["cz", "rz", "sx", "x"])


def test_ideal_target_is_noiseless_all_to_all():
    tgt = get_target("ideal", 3)
    assert isinstance(tgt, HardwareTarget)
    assert tgt.backend is None and tgt.noise_model is None and tgt.coupling_map is None
    assert {"cx", "cz", "h", "rz", "sx", "x", "ry", "rxx"} <= set(tgt.basis_gates)
    assert not tgt.is_noisy
    assert tgt.label == "ideal"
    assert get_target("ideal", 3, basis_gates=["cz", "rz", "sx", "x"]).label == "ideal[cz,rz,sx,x]"


# ----------------------------------------------------------------------------------------------
# connectivity


def _undirected(edges) -> set[frozenset]:
    return {frozenset(e) for e in edges}


def test_line_ring_all_to_all_coupling_maps():
    n = 5
    line = get_target("line", n, noise=False)
    ring = get_target("ring", n, noise=False)
    full = get_target("all_to_all", n, noise=False)
    path = {frozenset((i, i + 1)) for i in range(n - 1)}
    assert _undirected(line.coupling_map.get_edges()) == path
    assert _undirected(ring.coupling_map.get_edges()) == path | {frozenset((n - 1, 0))}
    assert _undirected(full.coupling_map.get_edges()) == {
        frozenset((i, j)) for i in range(n) for j in range(i + 1, n)
    }
    for tgt in (line, ring, full):
        assert tgt.num_qubits == n
        assert isinstance(tgt.backend, GenericBackendV2)
        assert tgt.noise_model is None


def test_heavy_hex_distance_is_smallest_odd_fit():
    sizes = {d: CouplingMap.from_heavy_hex(d).size() for d in (3, 5, 7)}
    assert sizes == {3: 19, 5: 57, 7: 115}
    for n in range(1, 116):
        d = heavy_hex_distance(n)
        assert d % 2 == 1 and d >= 3
        assert sizes[d] >= n
        assert d == 3 or sizes[d - 2] < n


def test_heavy_hex_target_uses_distance_three_lattice():
    tgt = get_target("heavy_hex", 5, noise=False)
    assert tgt.num_qubits == 19
    assert _undirected(tgt.coupling_map.get_edges()) == _undirected(
        CouplingMap.from_heavy_hex(3).get_edges()
    )


def _random_cx_circuit(n: int, depth: int, seed: int) -> QuantumCircuit:
    rng = np.random.default_rng(seed)
    qc = QuantumCircuit(n)
    for _ in range(depth):
        q = int(rng.integers(n))
        qc.rx(float(rng.uniform(-3, 3)), q)
        i, j = rng.choice(n, size=2, replace=False)
        qc.cx(int(i), int(j))
    return qc


@pytest.mark.parametrize("name", ["line", "ring", "all_to_all", "rbs_native"])
def test_transpile_respects_coupling_and_preserves_operator(name):
    tgt = get_target(name, 4, seed=3, noise=False)
    qc = _random_cx_circuit(4, 8, seed=11)
    out = tgt.transpile(qc)
    edges = set(tgt.coupling_map.get_edges())
    for inst in out.data:
        assert inst.operation.name in set(tgt.basis_gates) | {"barrier"}
        if len(inst.qubits) == 2:
            assert tuple(out.find_bit(q).index for q in inst.qubits) in edges
    assert Operator.from_circuit(out).equiv(Operator(qc))


def test_transpile_is_reproducible_and_keeps_shape():
    tgt = get_target("line", 5, seed=2, noise=False)
    qcs = [_random_cx_circuit(5, 10, seed=s) for s in range(3)]
    first = tgt.transpile(qcs, optimization_level=3, seed=8)
    second = tgt.transpile(qcs, optimization_level=3, seed=8)
    assert isinstance(first, list) and len(first) == 3
    assert first == second
    assert isinstance(tgt.transpile(qcs[0]), QuantumCircuit)
    assert tgt.transpile([]) == []


def test_transpile_refuses_wider_circuit_and_bad_level():
    tgt = get_target("line", 3, noise=False)
    with pytest.raises(ValueError) as info:
        tgt.transpile(QuantumCircuit(5))
    assert "5" in str(info.value) and "3" in str(info.value)
    with pytest.raises(ValueError, match="optimization_level"):
        tgt.transpile(QuantumCircuit(2), optimization_level=4)
    with pytest.raises(TypeError, match="circuits"):
        tgt.transpile("qc")


# ----------------------------------------------------------------------------------------------
# rbs_native


@pytest.mark.parametrize("level", [0, 1, 2, 3])
def test_rbs_native_one_native_gate_per_rbs(level):
    n = 4
    theta = ParameterVector("theta", 5)
    qc = QuantumCircuit(n)
    qc.x(0)
    for k, (i, j) in enumerate([(0, 1), (1, 2), (0, 3), (2, 3), (1, 3)]):
        qc.append(RBSGate(theta[k]), [i, j])
    tgt = get_target("rbs_native", n, noise=False)
    out = tgt.transpile(qc, optimization_level=level)
    ops = dict(out.count_ops())
    assert ops.get("xx_plus_yy") == 5
    assert sum(c for g, c in ops.items() if g != "x") == 5  # nothing but the native gates
    values = np.random.default_rng(level).uniform(-np.pi, np.pi, 5)
    assert Operator.from_circuit(out.assign_parameters(values)).equiv(
        Operator(qc.assign_parameters(values))
    )


def test_rbs_native_keeps_rbs_inside_fbs_native():
    qc = QuantumCircuit(4)
    qc.append(FBSGate(0.7, 4), [0, 1, 2, 3])
    qc.append(FBSGate(-0.4, 3), [1, 2, 3])
    out = get_target("rbs_native", 4, noise=False).transpile(qc)
    assert out.count_ops()["xx_plus_yy"] == 2
    assert set(out.count_ops()) <= set(RBS_NATIVE_BASIS)
    assert Operator.from_circuit(out).equiv(Operator(qc))


def test_rbs_native_noisy_density_matches_hand_channel():
    """x then one RBS on the rbs_native device, against the channels written out by hand."""
    theta = 0.83
    qc = QuantumCircuit(2)
    qc.x(0)
    qc.append(RBSGate(theta), [0, 1])
    tgt = get_target("rbs_native", 2, seed=1)
    out = tgt.transpile(qc)
    assert dict(out.count_ops()) == {"x": 1, "xx_plus_yy": 1}
    assert out.layout.final_index_layout() == [0, 1]
    out.save_density_matrix()
    got = np.asarray(tgt.simulator(method="density_matrix").run(out).result().data()[
        "density_matrix"])

    p = RBS_NATIVE_NOISE
    t1, t2 = p["t1"], p["t2"]
    rho = np.zeros((4, 4), dtype=complex)
    rho[1, 1] = 1.0  # x on qubit 0: |q1 q0> = |01>, index 1
    rho = depolarize_qubit(rho, 0, p["depolarizing_1q"])  # x gate error: depolarizing ...
    rho = relax_qubit(rho, 0, t1, t2, p["gate_time_1q"])  # ... then relaxation
    u = rbs(theta)
    rho = u @ rho @ u.conj().T
    rho = depolarize(rho, p["depolarizing_2q"])
    rho = relax_qubit(rho, 0, t1, t2, p["gate_time_2q"])
    rho = relax_qubit(rho, 1, t1, t2, p["gate_time_2q"])
    assert np.allclose(got, rho, atol=1e-10)
    # and the noise is really there: the ideal state differs by more than the tolerance
    ideal = Statevector(qc)
    assert not np.allclose(got, np.outer(ideal.data, ideal.data.conj()), atol=1e-4)



# ----------------------------------------------------------------------------------------------
# simulators, samplers, seeds


def test_same_seed_same_backend_noise_and_different_seed_differs():
    a = get_target("line", 3, seed=11)
    b = get_target("line", 3, seed=11)
    c = get_target("line", 3, seed=12)
    assert noise_content(a.noise_model) == noise_content(b.noise_model)
    assert noise_content(a.noise_model) != noise_content(c.noise_model)
    assert [a.backend.qubit_properties(q).t1 for q in range(3)] == [
        b.backend.qubit_properties(q).t1 for q in range(3)
    ]


def test_simulator_carries_noise_and_seed():
    tgt = get_target("ring", 3, seed=5)
    sim = tgt.simulator(method="density_matrix", seed=9)
    assert sim.options.noise_model is tgt.noise_model
    assert sim.options.seed_simulator == aer_seed(9)  # the seed, hashed (reproducible)
    assert sim.options.method == "density_matrix"
    assert tgt.simulator().options.seed_simulator == aer_seed(5)
    assert get_target("ring", 3, noise=False).simulator().options.noise_model is None




def test_simulator_rejects_bad_method_and_device(monkeypatch):
    tgt = get_target("ideal", 2)
    with pytest.raises(ValueError, match="method"):
        tgt.simulator(method="stabiliser")
    with pytest.raises(ValueError, match="device"):
        tgt.simulator(device="TPU")
    monkeypatch.setattr(targets_mod, "gpu_available", lambda: False)
    with pytest.raises(ValueError, match="qiskit-aer-gpu"):
        tgt.simulator(device="GPU")


def test_gpu_available_agrees_with_aer():
    assert gpu_available() == ("GPU" in AerSimulator().available_devices())
    if gpu_available():
        assert get_target("ideal", 2).simulator(device="GPU").options.device == "GPU"
    else:
        with pytest.raises(ValueError, match="qiskit-aer-gpu"):
            get_target("ideal", 2).simulator(device="GPU")


# ----------------------------------------------------------------------------------------------
# noise models from parameters


@pytest.mark.parametrize("p", [0.05, 0.2])
def test_readout_error_flips_outcome_with_probability_p(p):
    qc = QuantumCircuit(1, 1)
    qc.x(0)
    qc.measure(0, 0)
    shots = 20000
    sim = AerSimulator(noise_model=noise_model(readout_error=p), seed_simulator=17)
    counts = sim.run(qc, shots=shots).result().get_counts()
    freq = counts.get("0", 0) / shots
    assert abs(freq - p) <= 4 * math.sqrt(p * (1 - p) / shots)


@pytest.mark.parametrize("lam", [0.1, 0.35])
def test_two_qubit_depolarizing_on_bell_state(lam):
    model = noise_model(depolarizing_2q=lam, basis_gates=["cx", "h", "rz", "sx", "x"])
    bell = QuantumCircuit(2)
    bell.h(0)
    bell.cx(0, 1)
    exact = bell.copy()
    exact.save_density_matrix()
    rho = density_after(exact, model)
    zz = np.diag([1.0, -1.0, -1.0, 1.0])
    xx = np.fliplr(np.eye(4))
    assert np.isclose(np.trace(rho @ zz).real, 1 - lam, atol=1e-12)
    assert np.isclose(np.trace(rho @ xx).real, 1 - lam, atol=1e-12)
    sampled = bell.copy()
    sampled.measure_all()
    shots = 8000
    counts = AerSimulator(noise_model=model, seed_simulator=5).run(
        sampled, shots=shots).result().get_counts()
    est = (counts.get("00", 0) + counts.get("11", 0) - counts.get("01", 0)
           - counts.get("10", 0)) / shots
    se = math.sqrt((1 - (1 - lam) ** 2) / shots)
    assert abs(est - (1 - lam)) <= 4 * se


def test_t1_decay_of_excited_population():
    t1, tau, k = 50.0, 3.0, 6
    model = noise_model(t1=t1, gate_time_1q=tau, basis_gates=["id", "x", "rz", "sx"])
    qc = QuantumCircuit(1)
    qc.x(0)
    for _ in range(k):
        qc.id(0)
    qc.save_density_matrix()
    rho = density_after(qc, model)
    # x and k identities each last tau: P(1) = exp(-(k+1) tau / T1)
    assert np.isclose(rho[1, 1].real, math.exp(-(k + 1) * tau / t1), atol=1e-12)


@settings(max_examples=12, deadline=None)
@given(
    t1=st.floats(1.0, 100.0),
    ratio=st.floats(0.05, 2.0),
    tau=st.floats(0.01, 5.0),
    lam=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**16),
)
def test_one_qubit_error_is_depolarizing_then_relaxation(t1, ratio, tau, lam, seed):
    t2 = ratio * t1
    model = noise_model(depolarizing_1q=lam, t1=t1, t2=t2, gate_time_1q=tau,
                        basis_gates=["id", "cz"], gate_time_2q=1.0)
    rho0 = random_density(1, np.random.default_rng(seed))
    qc = QuantumCircuit(1)
    qc.set_density_matrix(rho0)
    qc.id(0)
    qc.save_density_matrix()
    expected = relax_qubit(depolarize(rho0, lam), 0, t1, t2, tau)
    assert np.allclose(density_after(qc, model), expected, atol=1e-10)


def test_two_qubit_error_and_defaults_for_missing_t1_or_t2():
    rng = np.random.default_rng(3)
    rho0 = random_density(2, rng)
    cz = np.diag([1.0, 1.0, 1.0, -1.0])
    for t1, t2, e1, e2 in [(40.0, None, 40.0, 80.0), (None, 30.0, math.inf, 30.0),
                           (40.0, 25.0, 40.0, 25.0)]:
        model = noise_model(depolarizing_2q=0.2, t1=t1, t2=t2, gate_time_2q=4.0,
                            basis_gates=["cz"])
        qc = QuantumCircuit(2)
        qc.set_density_matrix(rho0)
        qc.cz(0, 1)
        qc.save_density_matrix()
        expected = depolarize(cz @ rho0 @ cz, 0.2)
        expected = relax_qubit(relax_qubit(expected, 0, e1, e2, 4.0), 1, e1, e2, 4.0)
        assert np.allclose(density_after(qc, model), expected, atol=1e-10)


def test_virtual_rz_is_noiseless_and_other_gates_are_not():
    model = noise_model(depolarizing_1q=0.3, depolarizing_2q=0.1, readout_error=0.01)
    assert set(model.noise_instructions) == {"sx", "x", "cz", "measure"}
    assert noise_model().is_ideal()


def test_same_seed_identical_counts():
    model = noise_model(depolarizing_1q=0.05, depolarizing_2q=0.1, readout_error=0.03,
                        basis_gates=["cx", "h"])
    qc = QuantumCircuit(2)
    qc.h(0)
    qc.cx(0, 1)
    qc.measure_all()

    def run(seed):
        sim = AerSimulator(noise_model=model, seed_simulator=seed)
        return sim.run(qc, shots=300).result().get_counts()

    assert run(7) == run(7)
    assert run(7) != run(8)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"depolarizing_1q": -0.1}, "depolarizing_1q"), ({"depolarizing_2q": 1.5}, "depolarizing_2q"),
     ({"readout_error": float("nan")}, "readout_error"),
     ({"t1": 10.0, "t2": 25.0, "gate_time_1q": 1.0, "gate_time_2q": 1.0}, "t2 <= 2"),
     ({"t1": 0.0, "gate_time_1q": 1.0, "gate_time_2q": 1.0}, "t1"),
     ({"t1": 10.0, "gate_time_2q": 1.0}, "gate_time_1q"),
     ({"t1": 10.0, "gate_time_1q": 1.0}, "gate_time_2q"),
     ({"t1": 10.0, "gate_time_1q": -1.0, "gate_time_2q": 1.0}, "gate_time_1q"),
     ({"gate_time_1q": 1.0}, "gate_time_1q"),
     ({"basis_gates": ["cz", "bogus"]}, "bogus"), ({"basis_gates": ["ccx", "x"]}, "ccx")],
)
def test_noise_model_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        noise_model(**kwargs)


def test_noise_model_type_errors():
    with pytest.raises(TypeError, match="depolarizing_1q"):
        noise_model(depolarizing_1q="0.1")
    with pytest.raises(TypeError, match="basis_gates"):
        noise_model(basis_gates="cz")
    with pytest.raises(TypeError, match="backend"):
        noise_from_backend("not a backend")


def test_noise_from_backend_is_reproducible_and_carries_readout():
    a = noise_from_backend(GenericBackendV2(3, seed=4))
    b = noise_from_backend(GenericBackendV2(3, seed=4))
    assert noise_content(a) == noise_content(b)
    assert noise_content(a) != noise_content(noise_from_backend(GenericBackendV2(3, seed=5)))
    backend = GenericBackendV2(3, seed=4)
    qc = QuantumCircuit(1, 1)
    qc.measure(0, 0)
    shots = 20000
    p = backend.target["measure"][(0,)].error
    counts = AerSimulator(noise_model=a, seed_simulator=3).run(qc, shots=shots).result()
    freq = counts.get_counts().get("1", 0) / shots
    assert abs(freq - p) <= 4 * math.sqrt(max(p * (1 - p), 1e-6) / shots) + 1e-9


def test_xx_plus_yy_equals_rbs_used_by_native_target():
    for theta in (0.3, -1.1):
        qc = QuantumCircuit(2)
        qc.append(XXPlusYYGate(2 * theta, math.pi / 2), [0, 1])
        assert np.allclose(Operator(qc).data, rbs(theta))
