"""Tests for the hardware-efficient, equivariant, QCNN and re-uploading families.

Oracles are dense matrices built here from 2x2 Pauli/rotation matrices (qubit 0 is the
rightmost Kronecker factor, Qiskit's convention), scipy's ``expm``, brute-force and Burnside
counts of necklaces, and exact statevectors.
"""

from __future__ import annotations

import math
from functools import reduce
from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import transpile
from qiskit.quantum_info import Operator, SparsePauliOp, Statevector
from qiskit_aer import AerSimulator
from scipy.linalg import expm

from qdensity.analysis import instruction_generator, moments, parameter_of
from qdensity.circuits.ansatze.equivariant import (
    angle_encoding,
    equivariant_commuting,
    equivariant_noncommuting,
    equivariant_observable,
    translation_classes,
)
from qdensity.circuits.ansatze.hardware_efficient import hardware_efficient
from qdensity.circuits.ansatze.qcnn import qcnn, qcnn_layers, qcnn_readout_qubit
from qdensity.circuits.ansatze.reuploading import reuploading
from qdensity.datasets import bars_and_dots, chebyshev_dataset

# ----------------------------------------------------------------------------- dense oracles

I2 = np.eye(2, dtype=complex)
PAULI = {
    "I": I2,
    "X": np.array([[0, 1], [1, 0]], dtype=complex),
    "Y": np.array([[0, -1j], [1j, 0]], dtype=complex),
    "Z": np.array([[1, 0], [0, -1]], dtype=complex),
}
P0 = np.diag([1, 0]).astype(complex)
P1 = np.diag([0, 1]).astype(complex)


def rot(axis: str, angle: float) -> np.ndarray:
    """R_axis(angle) = cos(angle/2) I - i sin(angle/2) P."""
    return math.cos(angle / 2) * I2 - 1j * math.sin(angle / 2) * PAULI[axis.upper()]


def on(n: int, ops: dict[int, np.ndarray]) -> np.ndarray:
    """Tensor product with ``ops[q]`` on qubit q (identity elsewhere); qubit 0 rightmost."""
    return reduce(np.kron, [ops.get(q, I2) for q in reversed(range(n))])


def controlled(n: int, control: int, target: int, gate: np.ndarray) -> np.ndarray:
    return on(n, {control: P0}) + on(n, {control: P1, target: gate})


def cnot(n: int, control: int, target: int) -> np.ndarray:
    """CNOT as a permutation of basis indices (independent of the Kronecker helper)."""
    dim = 2**n
    mat = np.zeros((dim, dim))
    for b in range(dim):
        out = b ^ (1 << target) if (b >> control) & 1 else b
        mat[out, b] = 1
    return mat


def pauli_string(n: int, pauli: str, support) -> np.ndarray:
    return on(n, {q: PAULI[pauli] for q in support})


def necklaces(n: int, k: int) -> int:
    """Burnside: binary necklaces of length n with k ones."""
    total = 0
    for d in range(1, n + 1):
        if n % d == 0 and k % d == 0:
            phi = sum(1 for j in range(1, d + 1) if math.gcd(j, d) == 1)
            total += phi * math.comb(n // d, k // d)
    assert total % n == 0
    return total // n


def rotate_mask(mask: int, n: int, s: int) -> int:
    return ((mask << s) | (mask >> (n - s))) & ((1 << n) - 1)


def brute_classes(n: int, k: int) -> list[list[tuple[int, ...]]]:
    """Orbits of k-subsets under rotation, via bit masks; ordered by smallest member."""
    seen: set[int] = set()
    orbits = []
    for mask in range(1 << n):
        if bin(mask).count("1") != k or mask in seen:
            continue
        orbit = {rotate_mask(mask, n, s) for s in range(n)}
        seen |= orbit
        supports = sorted(tuple(q for q in range(n) if (m >> q) & 1) for m in orbit)
        orbits.append(supports)
    return sorted(orbits, key=lambda o: o[0])


def bind(circuit, values: dict[str, np.ndarray]):
    """Assign parameter vectors by name, e.g. {"θ": [...], "x": [...]}."""
    mapping = {}
    for p in circuit.parameters:
        vec = p.vector.name
        mapping[p] = float(values[vec][p.index])
    return circuit.assign_parameters(mapping)


def rng_angles(seed: int, size: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, size)


BASES = (["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"])

# Qiskit's PauliEvolutionGate.to_matrix calls scipy.sparse.linalg.expm on a CSR matrix, which
# warns about the sparse format; the result is exact, the warning is upstream noise.
pytestmark = pytest.mark.filterwarnings("ignore::scipy.sparse.SparseEfficiencyWarning")

# ----------------------------------------------------------------------- translation classes


@pytest.mark.parametrize("n", range(2, 10))
def test_class_counts_match_burnside_and_brute_force(n):
    for k_max in range(1, n + 1):
        classes = translation_classes(n, k_max)
        assert len(classes) == sum(necklaces(n, k) for k in range(1, k_max + 1))
    expected = [c for k in range(1, n + 1) for c in brute_classes(n, k)]
    assert translation_classes(n, n) == expected


@settings(max_examples=20, deadline=None)
@given(n=st.integers(2, 9), data=st.data())
def test_classes_partition_subsets_and_are_shift_closed(n, data):
    k_max = data.draw(st.integers(1, n))
    classes = translation_classes(n, k_max)
    flat = [s for c in classes for s in c]
    assert len(flat) == len(set(flat)) == sum(math.comb(n, k) for k in range(1, k_max + 1))
    for cls in classes:
        members = set(cls)
        for s in cls:
            assert tuple(sorted((q + 1) % n for q in s)) in members


def test_xx_model_on_ten_qubits_has_18_parameters():
    qc = equivariant_commuting(10, "X", max_weight=3)
    assert qc.num_parameters == 18
    assert [necklaces(10, k) for k in (1, 2, 3)] == [1, 5, 12]
    assert len(qc.data) == 10 + 45 + 120


# ------------------------------------------------------------------- equivariant commuting


def sym_generators(n: int, pauli: str, k_max: int) -> list[np.ndarray]:
    return [
        sum(pauli_string(n, pauli, s) for s in cls)
        for k in range(1, k_max + 1)
        for cls in brute_classes(n, k)
    ]


@pytest.mark.parametrize("n", [4, 5])
@pytest.mark.parametrize("pauli", ["X", "Y"])
def test_commuting_model_equals_expm_of_symmetrised_generators(n, pauli):
    k_max = 3
    qc = equivariant_commuting(n, pauli, max_weight=k_max)
    gens = sym_generators(n, pauli, k_max)
    assert qc.num_parameters == len(gens)
    theta = rng_angles(n, len(gens))
    expected = expm(-1j * sum(t * g for t, g in zip(theta, gens, strict=True)))
    np.testing.assert_allclose(Operator(bind(qc, {"θ": theta})).data, expected, atol=1e-10)


@pytest.mark.parametrize("n", [4, 5])
def test_commuting_generators_commute_and_are_readable(n):
    qc = equivariant_commuting(n, "Y", max_weight=n)
    gens = [instruction_generator(inst, qc) for inst in qc.data]
    for a, b in combinations(gens[:: max(1, len(gens) // 12)], 2):
        comm = (a @ b - b @ a).simplify(atol=1e-12)
        assert np.allclose(comm.coeffs, 0)
    dense = sym_generators(n, "Y", n)
    for g_dense_a, g_dense_b in combinations(dense, 2):
        assert np.allclose(g_dense_a @ g_dense_b, g_dense_b @ g_dense_a)
    # each instruction: generator P_S with unit coefficient, angle = class parameter
    by_param: dict[str, np.ndarray] = {}
    for inst, gen in zip(qc.data, gens, strict=True):
        param, coeff = parameter_of(inst)
        assert coeff == 1.0
        assert len(gen) == 1 and gen.paulis[0].to_label().replace("I", "") == "Y" * len(
            inst.qubits
        )
        by_param[param.name] = by_param.get(param.name, 0) + gen.to_matrix()
    assert len(by_param) == len(dense)
    for c, g in enumerate(dense):
        np.testing.assert_allclose(by_param[f"θ[{c}]"], g, atol=1e-12)


def expectation(circuit, observable: np.ndarray) -> float:
    psi = Statevector(circuit).data
    return float(np.real(np.conj(psi) @ observable @ psi))


@pytest.mark.parametrize("n", [5, 6])
@pytest.mark.parametrize("model", ["XX", "YY", "noncommuting"])
def test_equivariance_under_cyclic_shift(n, model):
    if model == "noncommuting":
        ansatz = equivariant_noncommuting(n, 2)
    else:
        ansatz = equivariant_commuting(n, model[0], max_weight=3)
    qc = angle_encoding(n).compose(ansatz)
    obs = sum(on(n, {i: PAULI["Z"]}) for i in range(n))
    np.testing.assert_allclose(equivariant_observable(n).to_matrix(), obs)
    rng = np.random.default_rng(7 * n)
    theta = rng.uniform(-np.pi, np.pi, ansatz.num_parameters)
    values = []
    for _ in range(3):
        x = rng.normal(0, 1, n)
        f = expectation(bind(qc, {"θ": theta, "x": x}), obs)
        for shift in (1, 2, n - 1):
            g = expectation(bind(qc, {"θ": theta, "x": np.roll(x, shift)}), obs)
            assert g == pytest.approx(f, abs=1e-10)
        values.append(f)
    assert np.ptp(values) > 1e-3  # the model is not constant in x


def test_angle_encoding_state():
    x = np.array([0.3, -1.2, 2.0])
    psi = Statevector(bind(angle_encoding(3), {"x": x})).data
    qubits = [np.array([math.cos(math.pi * xi / 4), math.sin(math.pi * xi / 4)]) for xi in x]
    np.testing.assert_allclose(psi, reduce(np.kron, qubits[::-1]), atol=1e-12)


# --------------------------------------------------------------- equivariant non-commuting


@pytest.mark.parametrize("n", [4, 5])
def test_noncommuting_model_equals_layered_expm(n):
    layers = 2
    qc = equivariant_noncommuting(n, layers)
    per_layer = 2 + n // 2
    assert qc.num_parameters == layers * per_layer
    theta = rng_angles(11 + n, layers * per_layer)
    z_sum = sum(pauli_string(n, "Z", [i]) for i in range(n))
    y_sum = sum(pauli_string(n, "Y", [i]) for i in range(n))
    xx = []
    for d in range(1, n // 2 + 1):
        pairs = {frozenset((i, (i + d) % n)) for i in range(n)}
        xx.append(sum(pauli_string(n, "X", sorted(p)) for p in pairs))
    u = np.eye(2**n, dtype=complex)
    for layer in range(layers):
        t = theta[layer * per_layer : (layer + 1) * per_layer]
        for angle, gen in zip(t, [z_sum, y_sum, *xx], strict=True):
            u = expm(-1j * angle * gen) @ u
    np.testing.assert_allclose(Operator(bind(qc, {"θ": theta})).data, u, atol=1e-10)
    # the factors do not commute (it is a genuinely non-commuting model)
    assert not np.allclose(z_sum @ y_sum, y_sum @ z_sum)


def test_noncommuting_even_n_half_distance_class_has_n_over_2_strings():
    qc = equivariant_noncommuting(6, 1)
    xx_on_d3 = [
        inst for inst in qc.data
        if len(inst.qubits) == 2 and parameter_of(inst)[0].index == 2 + 2
    ]
    assert sorted(tuple(qc.find_bit(q).index for q in i.qubits) for i in xx_on_d3) == [
        (0, 3), (1, 4), (2, 5)
    ]


# ------------------------------------------------------------------------ hardware-efficient


def hwe_dense(n, reps, rotations, theta, ring=False):
    u = np.eye(2**n, dtype=complex)
    for d in range(reps):
        axis = rotations[d % len(rotations)][1]
        u = on(n, {q: rot(axis, theta[d * n + q]) for q in range(n)}) @ u
        pairs = [(i, i + 1) for i in range(n - 1)] + ([(n - 1, 0)] if ring else [])
        if d % 2:
            pairs = [(t, c) for c, t in reversed(pairs)]
        for c, t in pairs:
            u = cnot(n, c, t) @ u
    return u


@pytest.mark.parametrize(
    "n,reps,rotations,ent",
    [(3, 3, ("rx", "ry", "rz"), "ladder"), (4, 2, ("ry",), "ladder"), (4, 3, ("rz", "rx"), "ring")],
)
def test_hardware_efficient_operator_matches_dense_product(n, reps, rotations, ent):
    qc = hardware_efficient(n, reps, rotations=rotations, entanglement=ent)
    assert qc.num_parameters == n * reps
    theta = rng_angles(n * reps, n * reps)
    expected = hwe_dense(n, reps, rotations, theta, ring=ent == "ring")
    np.testing.assert_allclose(Operator(bind(qc, {"θ": theta})).data, expected, atol=1e-10)


def test_hardware_efficient_cnot_directions_alternate_and_layers_are_moments():
    n, reps = 5, 4
    qc = hardware_efficient(n, reps, rotations=("rx", "ry", "rz"))
    cx = [
        tuple(qc.find_bit(q).index for q in inst.qubits)
        for inst in qc.data
        if inst.operation.name == "cx"
    ]
    forward = [(0, 1), (1, 2), (2, 3), (3, 4)]
    backward = [(4, 3), (3, 2), (2, 1), (1, 0)]
    assert cx == forward + backward + forward + backward
    layers = moments(qc, include_unparameterised=False)
    assert len(layers) == reps
    for d, layer in enumerate(layers):
        assert [inst.operation.name for inst in layer] == ["rx", "ry", "rz"][d % 3:][:1] * n
        assert [parameter_of(inst)[0].index for inst in layer] == list(range(d * n, d * n + n))
    assert hardware_efficient(3, 2, "rz").count_ops()["rz"] == 6


# -------------------------------------------------------------------------------------- QCNN


def conv_dense(n, phi, u, v):
    mats = [
        on(n, {u: rot("x", phi[0])}), on(n, {v: rot("x", phi[1])}),
        on(n, {u: rot("z", phi[2])}), on(n, {v: rot("z", phi[3])}),
        controlled(n, v, u, rot("z", phi[4])), controlled(n, u, v, rot("z", phi[5])),
        on(n, {u: rot("x", phi[6])}), on(n, {v: rot("x", phi[7])}),
        on(n, {u: rot("z", phi[8])}), on(n, {v: rot("z", phi[9])}),
    ]
    return reduce(lambda acc, m: m @ acc, mats, np.eye(2**n, dtype=complex))


def pool_dense(n, psi, c, t):
    x = on(n, {c: PAULI["X"]})
    return x @ controlled(n, c, t, rot("x", psi[1])) @ x @ controlled(n, c, t, rot("z", psi[0]))


# hand-written layouts: per layer (convolution pairs in order, pooling (discarded, kept))
HAND_LAYOUTS = {
    2: [([(0, 1)], [(0, 1)])],
    4: [
        ([(0, 1), (2, 3), (1, 2), (3, 0)], [(0, 1), (2, 3)]),
        ([(1, 3)], [(1, 3)]),
    ],
    5: [
        ([(0, 1), (2, 3), (4, 0), (1, 2), (3, 4)], [(0, 1), (2, 3)]),
        ([(1, 3), (4, 1), (3, 4)], [(1, 3)]),
        ([(3, 4)], [(3, 4)]),
    ],
}


@pytest.mark.parametrize("n", sorted(HAND_LAYOUTS))
def test_qcnn_operator_matches_hand_built_dense_product(n):
    qc = qcnn(n)
    layout = HAND_LAYOUTS[n]
    assert qc.num_parameters == 12 * len(layout)
    theta = rng_angles(100 + n, qc.num_parameters)
    u = np.eye(2**n, dtype=complex)
    for layer, (conv, pool) in enumerate(layout):
        phi, psi = theta[12 * layer : 12 * layer + 10], theta[12 * layer + 10 : 12 * layer + 12]
        for a, b in conv:
            u = conv_dense(n, phi, a, b) @ u
        for c, t in pool:
            u = pool_dense(n, psi, c, t) @ u
    np.testing.assert_allclose(Operator(bind(qc, {"θ": theta})).data, u, atol=1e-10)


@pytest.mark.parametrize("n", range(4, 10))
def test_qcnn_structure(n):
    qc = qcnn(n)
    num_layers = math.ceil(math.log2(n))
    assert qc.num_qubits == n
    assert qc.num_parameters == 12 * num_layers
    assert len(qcnn_layers(n)) == num_layers
    readout = qcnn_readout_qubit(n)
    assert readout == n - 1
    # pooling controls are discarded: never touched afterwards; the readout is never discarded
    discarded: set[int] = set()
    pending = None  # the pooling block ends with an X on its control; discard after it
    expected_conv, expected_pool, m = 0, 0, n
    for inst in qc.data:
        qubits = [qc.find_bit(q).index for q in inst.qubits]
        assert not discarded & set(qubits), (inst.operation.name, qubits)
        if inst.operation.name == "crx":
            pending = qubits[0]
        elif inst.operation.name == "x" and qubits == [pending]:
            discarded.add(pending)
            pending = None
    assert discarded == set(range(n)) - {readout}
    while m > 1:
        expected_conv += m if m > 2 else 1
        expected_pool += m // 2
        m = (m + 1) // 2
    ops = qc.count_ops()
    assert ops["crx"] == expected_pool == n - 1
    assert ops["crz"] == 2 * expected_conv + expected_pool
    # every qubit is in the backward light cone of the readout
    cone = {readout}
    for inst in reversed(qc.data):
        qubits = {qc.find_bit(q).index for q in inst.qubits}
        if qubits & cone:
            cone |= qubits
    assert cone == set(range(n))


def test_qcnn_is_identity_at_zero_parameters():
    qc = qcnn(6)
    zero = bind(qc, {"θ": np.zeros(qc.num_parameters)})
    np.testing.assert_allclose(Operator(zero).data, np.eye(2**6), atol=1e-12)


def test_qcnn_sixteen_qubits_matches_bowles_block_counts():
    qc = qcnn(16)
    assert qc.num_parameters == 48
    assert qc.count_ops()["crx"] == 15
    assert qc.count_ops()["crz"] == 2 * 29 + 15


# ------------------------------------------------------------------------------ reuploading


@pytest.mark.parametrize("encoding", ["rx", "ry"])
@pytest.mark.parametrize("layers", [1, 3])
def test_reuploading_operator_is_product_of_2x2(encoding, layers):
    qc = reuploading(layers, encoding=encoding)
    assert qc.num_qubits == 1
    assert qc.num_parameters == 3 * layers + 1
    rng = np.random.default_rng(layers)
    theta, x = rng.uniform(-np.pi, np.pi, 3 * layers), rng.uniform(-1, 1, 1)
    u = I2
    for ell in range(layers):
        t1, t2, t3 = theta[3 * ell : 3 * ell + 3]
        u_ell = rot("z", t1) @ rot("y", t2) @ rot("z", t3)
        u = u_ell @ rot(encoding[1], x[0]) @ u
    np.testing.assert_allclose(Operator(bind(qc, {"θ": theta, "x": x})).data, u, atol=1e-12)


def test_reuploading_is_a_fourier_series_of_degree_layers():
    layers = 3
    qc = reuploading(layers)
    theta = rng_angles(5, 3 * layers)
    m = 16
    xs = 2 * np.pi * np.arange(m) / m
    f = [expectation(bind(qc, {"θ": theta, "x": [x]}), PAULI["Z"]) for x in xs]
    spectrum = np.abs(np.fft.fft(f)) / m
    assert np.all(spectrum[layers + 1 : m - layers] < 1e-10)
    assert spectrum[layers] > 1e-6


# --------------------------------------------------------------- transpile and run on Aer

BUILDERS = {
    "hardware_efficient": lambda: hardware_efficient(4, 2, rotations=("rx", "ry")),
    "hardware_efficient_ring": lambda: hardware_efficient(3, 2, entanglement="ring"),
    "xx": lambda: equivariant_commuting(4, "X", max_weight=3),
    "yy": lambda: equivariant_commuting(4, "Y", max_weight=2),
    "noncommuting": lambda: equivariant_noncommuting(4, 2),
    "angle_encoding": lambda: angle_encoding(3),
    "qcnn": lambda: qcnn(5),
    "reuploading": lambda: reuploading(3),
}


@pytest.mark.parametrize("builder", sorted(BUILDERS))
@pytest.mark.parametrize("basis", BASES, ids=["cz", "cx"])
def test_transpiles_to_basis_and_runs_on_aer(builder, basis):
    qc = BUILDERS[builder]()
    rng = np.random.default_rng(len(builder))
    bound = qc.assign_parameters(rng.uniform(-1, 1, qc.num_parameters))
    tqc = transpile(bound, basis_gates=basis, optimization_level=1, seed_transpiler=1)
    assert set(tqc.count_ops()) <= set(basis)
    assert Operator(tqc).equiv(Operator(bound))
    # transpiling the parameterised template works too
    template = transpile(qc, basis_gates=basis, optimization_level=1, seed_transpiler=1)
    assert template.num_parameters == qc.num_parameters
    tqc.measure_all()
    counts = AerSimulator().run(tqc, shots=64, seed_simulator=1).result().get_counts()
    assert sum(counts.values()) == 64


# ------------------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: hardware_efficient(1, 2), "num_qubits"),
        (lambda: hardware_efficient(3, 0), "reps"),
        (lambda: hardware_efficient(3, 1, rotations=("ry", "u")), "rotations"),
        (lambda: hardware_efficient(3, 1, rotations=()), "rotations"),
        (lambda: hardware_efficient(3, 1, entanglement="full"), "entanglement"),
        (lambda: equivariant_commuting(4, "W"), "pauli"),
        (lambda: equivariant_commuting(4, "X", max_weight=5), "max_weight"),
        (lambda: equivariant_commuting(4, "X", max_weight=0), "max_weight"),
        (lambda: equivariant_commuting(1), "num_qubits"),
        (lambda: translation_classes(3, 4), "max_weight"),
        (lambda: equivariant_noncommuting(4, 0), "layers"),
        (lambda: equivariant_noncommuting(1, 1), "num_qubits"),
        (lambda: qcnn(1), "num_qubits"),
        (lambda: reuploading(0), "layers"),
        (lambda: reuploading(2, encoding="rz"), "encoding"),
        (lambda: bars_and_dots(10, 3), "num_qubits"),
        (lambda: bars_and_dots(0, 6), "num_samples"),
        (lambda: bars_and_dots(10, 6, noise_std=-1.0), "noise_std"),
        (lambda: chebyshev_dataset(10, degree=-1), "degree"),
        (lambda: chebyshev_dataset(10, noise_std=float("nan")), "noise_std"),
        (lambda: angle_encoding(0), "num_qubits"),
    ],
)
def test_bad_input_raises_value_error_naming_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_bad_types_raise_type_error():
    with pytest.raises(TypeError, match="num_qubits"):
        hardware_efficient(3.0, 2)
    with pytest.raises(TypeError, match="layers"):
        reuploading(True)
    with pytest.raises(TypeError, match="seed"):
        bars_and_dots(3, 4, seed="abc")


def test_observable_is_sparse_pauli_op():
    obs = equivariant_observable(3)
    assert isinstance(obs, SparsePauliOp)
    assert sorted(obs.paulis.to_labels()) == ["IIZ", "IZI", "ZII"]
