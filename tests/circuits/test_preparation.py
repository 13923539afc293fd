"""Density-QNN preparation circuits (Fig. 1a/b/c, Fig. 13, Supp. I.2-I.3) against exact oracles.

Oracles (docs/design.md, "Oracles"): controlled gates against ``|0><0| (x) I + |1><1| (x) U``
built from ``Operator(U)``; the deterministic circuit's data marginal (``partial_trace`` over
``mix``) against ``sum_k alpha_k U_k rho U_k^dagger``; the LCU post-selected state against
``sum_k alpha_k U_k |x>`` normalised; Fig. 13b against ``sum_k alpha_k U_k |e_s><e_s| U_k^dagger``.
All oracle matrices are computed here with numpy from ``Operator``/``Statevector``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit import QuantumCircuit, transpile
from qiskit.circuit import Parameter, ParameterVector
from qiskit.circuit.library import PauliEvolutionGate, XXPlusYYGate
from qiskit.quantum_info import DensityMatrix, Operator, SparsePauliOp, Statevector, partial_trace
from qiskit_aer import AerSimulator

from qdensity.circuits.ansatze import pairs_circuit, pyramid, round_robin, round_robin_pairs
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.circuits.loaders import unary_loader, unary_loader_template
from qdensity.circuits.preparation import (
    PreparationCircuits,
    controlled_subunitary,
    deterministic_circuit,
    hw_generative_circuit,
    lcu_circuit,
    lcu_postselected_state,
    lcu_success_probability,
    prepare_all,
    randomised_circuits,
)

ATOL = 1e-10
BASES = (["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"])
P0 = np.diag([1.0, 0.0])
P1 = np.diag([0.0, 1.0])


# ----------------------------------------------------------------------------- helpers


def bind_random(circuits, rng):
    """Bind every free parameter of the given circuits to one shared random value per name."""
    values = {}
    for c in circuits:
        for p in c.parameters:
            values.setdefault(p.name, float(rng.uniform(-np.pi, np.pi)))
    return values


def bound(circuit, values):
    return circuit.assign_parameters({p: values[p.name] for p in circuit.parameters})


def hea(n, prefix, layers=1):
    """Hardware-efficient-like: rx and ry on every qubit, a CNOT ladder, repeated."""
    theta = ParameterVector(prefix, 2 * n * layers)
    qc = QuantumCircuit(n, name=f"hea_{prefix}")
    k = 0
    for _ in range(layers):
        for q in range(n):
            qc.rx(theta[k], q)
            qc.ry(theta[k + 1], q)
            k += 2
        for q in range(n - 1):
            qc.cx(q, q + 1)
    return qc


def pauli_circuit(n, prefix):
    """rzz / rxx / ryy chain plus single-term PauliEvolutionGates on all qubits, an rz layer."""
    theta = ParameterVector(prefix, (n - 1) + 2 + n)
    qc = QuantumCircuit(n, name=f"pauli_{prefix}")
    k = 0
    kinds = ["rzz", "rxx", "ryy"]
    for q in range(n - 1):
        getattr(qc, kinds[q % 3])(theta[k], q, q + 1)
        k += 1
    letters = "".join("XYZ"[q % 3] for q in range(n))
    qc.append(PauliEvolutionGate(SparsePauliOp([letters], [0.7]), time=theta[k]), range(n))
    k += 1
    qc.append(PauliEvolutionGate(SparsePauliOp(["Z" * n], [-1.3]), time=theta[k]), range(n))
    k += 1
    for q in range(n):
        qc.rz(theta[k], q)
        k += 1
    return qc


def round_robin_layer(n, k, prefix):
    """Layer ``k`` of the round-robin ansatz as its own sub-unitary (Fig. 6 decomposition)."""
    rounds = round_robin_pairs(n)
    return pairs_circuit(n, [rounds[k % len(rounds)]], parameter_prefix=prefix)


def fbs_circuit(n, prefix):
    """FBS gates on growing blocks (compound circuit, Supp. E.2) plus one RBS."""
    theta = ParameterVector(prefix, n)
    qc = QuantumCircuit(n)
    for m in range(2, n + 1):
        qc.append(FBSGate(theta[m - 2], m), list(range(m)))
    qc.append(RBSGate(theta[n - 1]), [0, n - 1])
    return qc


FAMILIES = {
    "round_robin_layer": lambda n, k: round_robin_layer(n, k, f"r{k}"),
    "pyramid": lambda n, k: pyramid(n, parameter_prefix=f"p{k}"),
    "round_robin": lambda n, k: round_robin(n, parameter_prefix=f"rr{k}"),
    "hea": lambda n, k: hea(n, f"h{k}"),
    "pauli": lambda n, k: pauli_circuit(n, f"z{k}"),
    "fbs": lambda n, k: fbs_circuit(n, f"f{k}"),
}
HW_FAMILIES = ("round_robin_layer", "pyramid", "round_robin", "fbs")


def make_subs(n, K, rng, families=tuple(FAMILIES)):
    return [FAMILIES[families[int(rng.integers(len(families)))]](n, k) for k in range(K)]


def random_alpha(K, rng, zeros=False):
    alpha = rng.dirichlet(np.ones(K))
    if zeros and K > 1:
        drop = rng.choice(K, size=int(rng.integers(1, K)), replace=False)
        alpha[drop] = 0.0
        alpha /= alpha.sum()
    return alpha


def random_loader(n, rng):
    x = rng.normal(size=n)
    return unary_loader(x) if n >= 2 else None


def controlled_oracle(u: np.ndarray) -> np.ndarray:
    """|0><0| on the control (least significant qubit) (x) I + |1><1| (x) U, Qiskit order."""
    return np.kron(np.eye(u.shape[0]), P0) + np.kron(u, P1)


def mixture_of_pure(alpha, us, x):
    """sum_k alpha_k U_k |x><x| U_k^dagger (paper eq. 1), with numpy."""
    return sum(a * np.outer(u @ x, (u @ x).conj()) for a, u in zip(alpha, us, strict=True))


def unitaries(subs, values):
    return [Operator(bound(c, values)).data for c in subs]


# ------------------------------------------------------------ controlled sub-unitaries


def _single(name, t=None):
    t = Parameter("t") if t is None else t
    qc = QuantumCircuit(4)
    if name in ("rx", "ry", "rz", "p"):
        getattr(qc, name)(t, 1)
    elif name == "u":
        qc.u(t, 0.4 * t, -0.3, 2)
    elif name == "rbs":
        qc.append(RBSGate(t), [0, 2])
    elif name == "rbs_reversed":
        qc.append(RBSGate(-2 * t), [3, 1])
    elif name == "fbs3":
        qc.append(FBSGate(t, 3), [1, 2, 3])
    elif name == "fbs4":
        qc.append(FBSGate(t, 4), [0, 1, 2, 3])
    elif name in ("rzz", "rxx", "ryy", "rzx"):
        getattr(qc, name)(t, 3, 0)
    elif name == "pauli_xyz":
        qc.append(PauliEvolutionGate(SparsePauliOp(["XYZ"], [0.7]), time=t), [0, 2, 3])
    elif name == "pauli_with_identity":
        qc.append(PauliEvolutionGate(SparsePauliOp(["YIX"], [-1.1]), time=t), [1, 2, 3])
    elif name == "pauli_identity":
        qc.append(PauliEvolutionGate(SparsePauliOp(["II"], [0.5]), time=t), [1, 2])
    elif name == "pauli_commuting":
        qc.append(PauliEvolutionGate(SparsePauliOp(["XX", "ZZ"], [0.7, 0.3]), time=t), [0, 3])
    elif name == "pauli_noncommuting":
        qc.append(PauliEvolutionGate(SparsePauliOp(["XY", "ZI"], [0.7, 0.3]), time=t), [2, 1])
    elif name in ("crz", "crx", "cp"):
        getattr(qc, name)(t, 2, 0)
    elif name == "xx_plus_yy":
        qc.append(XXPlusYYGate(t, 0.3), [1, 3])
    elif name == "xx_plus_yy_bound":
        qc.append(XXPlusYYGate(0.9, -0.2), [1, 3])
    elif name in ("cx", "cz", "swap"):
        getattr(qc, name)(0, 3)
    elif name in ("h", "x", "s", "sdg", "sx", "t", "y"):
        getattr(qc, name)(2)
    elif name == "ccx":
        qc.ccx(0, 1, 3)
    elif name == "global_phase":
        qc.global_phase = 0.5 * t + 0.2
        qc.rx(t, 0)
    elif name == "bound_rotations":
        qc.rx(0.3, 0)
        qc.append(RBSGate(1.1), [1, 2])
        qc.rzz(-0.4, 2, 3)
    else:  # pragma: no cover - test table typo
        raise KeyError(name)
    return qc


GATE_KINDS = [
    "rx", "ry", "rz", "p", "u", "rbs", "rbs_reversed", "fbs3", "fbs4", "rzz", "rxx", "ryy",
    "rzx", "pauli_xyz", "pauli_with_identity", "pauli_identity", "pauli_commuting",
    "pauli_noncommuting", "crz", "crx", "cp", "xx_plus_yy", "xx_plus_yy_bound", "cx", "cz",
    "swap", "h", "x", "s", "sdg", "sx", "t", "y", "ccx", "global_phase", "bound_rotations",
]


@pytest.mark.parametrize("kind", GATE_KINDS)
def test_controlled_gate_matches_oracle(kind):
    qc = _single(kind)
    cu = controlled_subunitary(qc)
    assert cu.num_qubits == qc.num_qubits + 1
    assert {p.name for p in cu.parameters} == {p.name for p in qc.parameters}
    rng = np.random.default_rng(GATE_KINDS.index(kind))
    for _ in range(3):
        values = {p.name: float(rng.uniform(-np.pi, np.pi)) for p in qc.parameters}
        target = bound(qc, values)
        if kind == "pauli_noncommuting":
            # Operator() exponentiates the sum exactly, but what runs is the gate's synthesis
            # (Lie-Trotter product); the controlled version controls what runs.
            target = target.decompose()
        u = Operator(target).data
        got = Operator(bound(cu, values)).data
        np.testing.assert_allclose(got, controlled_oracle(u), atol=ATOL)


def test_controlled_rbs_controls_only_the_rotations():
    qc = QuantumCircuit(2)
    qc.append(RBSGate(Parameter("t")), [0, 1])
    ops = controlled_subunitary(qc).count_ops()
    assert dict(ops) == {"h": 4, "cz": 2, "cry": 2}


def test_controlled_fbs_and_pauli_rotations_leave_the_conjugation_uncontrolled():
    ops = controlled_subunitary(_single("fbs4")).count_ops()
    assert ops["cry"] == 2 and ops["cz"] == 4 and ops["cx"] == 2
    assert "ccx" not in ops and "ccz" not in ops
    ops = controlled_subunitary(_single("pauli_xyz")).count_ops()
    assert ops["crz"] == 1 and ops["cx"] == 4 and len([k for k in ops if k.startswith("cc")]) == 0
    ops = controlled_subunitary(_single("rzz")).count_ops()
    assert dict(ops) == {"cx": 2, "crz": 1}


@settings(max_examples=12, deadline=None)
@given(
    n=st.integers(2, 4),
    family=st.sampled_from(sorted(FAMILIES)),
    seed=st.integers(0, 2**16),
)
def test_controlled_subunitary_of_families(n, family, seed):
    rng = np.random.default_rng(seed)
    qc = FAMILIES[family](n, 0)
    values = bind_random([qc], rng)
    got = Operator(bound(controlled_subunitary(qc), values)).data
    u = Operator(bound(qc, values)).data
    np.testing.assert_allclose(got, controlled_oracle(u), atol=ATOL)


def test_controlled_subunitary_transpiles_parameterised():
    qc = QuantumCircuit(4)
    for kind in GATE_KINDS:
        qc.compose(_single(kind, Parameter(f"t_{kind}")), inplace=True)
    cu = controlled_subunitary(qc)
    rng = np.random.default_rng(3)
    values = bind_random([qc], rng)
    # multi-term PauliEvolution: what runs is its synthesis (see the test above)
    runs = bound(qc, values).decompose(gates_to_decompose=["PauliEvolution"])
    expected = controlled_oracle(Operator(runs).data)
    for basis in BASES:
        tqc = transpile(cu, basis_gates=basis, optimization_level=1, seed_transpiler=1)
        assert set(tqc.count_ops()) <= set(basis)
        got = Operator.from_circuit(bound(tqc, values)).data
        np.testing.assert_allclose(got, expected, atol=1e-8)


def test_controlled_subunitary_rejects_non_unitary():
    qc = QuantumCircuit(2, 1)
    qc.h(0)
    qc.measure(0, 0)
    with pytest.raises(ValueError, match="measure"):
        controlled_subunitary(qc)
    qc = QuantumCircuit(2)
    qc.reset(1)
    with pytest.raises(ValueError, match="reset"):
        controlled_subunitary(qc)
    with pytest.raises(TypeError, match="circuit"):
        controlled_subunitary("rbs")


# ---------------------------------------------------------------- density preparations


@settings(max_examples=15, deadline=None)
@given(
    n=st.integers(2, 4),
    K=st.integers(1, 4),
    seed=st.integers(0, 2**16),
    zeros=st.booleans(),
    with_loader=st.booleans(),
)
def test_deterministic_reduced_state_is_the_density_state(n, K, seed, zeros, with_loader):
    rng = np.random.default_rng(seed)
    subs = make_subs(n, K, rng)
    alpha = random_alpha(K, rng, zeros=zeros)
    loader = random_loader(n, rng) if with_loader else None
    qc = deterministic_circuit(subs, alpha, loader)
    assert [r.name for r in qc.qregs] == ["mix", "data"]
    assert [r.size for r in qc.qregs] == [K, n]
    values = bind_random(subs, rng)
    x = Statevector(loader) if loader is not None else Statevector.from_label("0" * n)
    rho = DensityMatrix(x).data
    us = unitaries(subs, values)
    expected = sum(a * u @ rho @ u.conj().T for a, u in zip(alpha, us, strict=True))
    got = partial_trace(Statevector(bound(qc, values)), list(range(K))).data
    np.testing.assert_allclose(got, expected, atol=ATOL)


def test_deterministic_with_data_template_binds_per_row():
    rng = np.random.default_rng(11)
    n, K = 3, 3
    subs = [round_robin_layer(n, k, f"l{k}") for k in range(K)]
    alpha = np.array([0.5, 0.0, 0.5])
    template = unary_loader_template(n)
    qc = deterministic_circuit(subs, alpha, template)
    values = bind_random(subs, rng)
    for _ in range(2):  # two data rows through one template
        row = bind_random([template], rng)
        values.update(row)
        x = Statevector(bound(template, row)).data
        expected = mixture_of_pure(alpha, unitaries(subs, values), x)
        got = partial_trace(Statevector(bound(qc, values)), list(range(K))).data
        np.testing.assert_allclose(got, expected, atol=ATOL)


@settings(max_examples=12, deadline=None)
@given(n=st.integers(2, 4), K=st.integers(1, 4), seed=st.integers(0, 2**16), zeros=st.booleans())
def test_lcu_postselected_state_and_probability(n, K, seed, zeros):
    rng = np.random.default_rng(seed)
    subs = make_subs(n, K, rng)
    alpha = random_alpha(K, rng, zeros=zeros)
    loader = random_loader(n, rng)
    values = bind_random(subs, rng)
    x = Statevector(loader).data
    ax = sum(a * u @ x for a, u in zip(alpha, unitaries(subs, values), strict=True))
    norm2 = float(np.vdot(ax, ax).real)
    assert norm2 > 1e-6  # hypothesis draws generic angles
    sv = Statevector(bound(lcu_circuit(subs, alpha, loader), values)).data
    # mix = qubits 0..K-1: mix = 0...0 are the entries whose K low bits vanish
    idx = np.array([d << K for d in range(2**n)])
    post = sv[idx]
    np.testing.assert_allclose(np.vdot(post, post).real, norm2, atol=ATOL)
    np.testing.assert_allclose(post / np.linalg.norm(post), ax / np.sqrt(norm2), atol=1e-9)
    bound_subs = [bound(c, values) for c in subs]
    np.testing.assert_allclose(lcu_success_probability(bound_subs, alpha, loader), norm2,
                               atol=ATOL)
    np.testing.assert_allclose(
        lcu_success_probability(bound_subs, alpha, Statevector(x)), norm2, atol=ATOL
    )
    state = lcu_postselected_state(bound_subs, alpha, loader)
    np.testing.assert_allclose(state.data, ax / np.sqrt(norm2), atol=1e-9)


def test_lcu_success_probability_closed_form():
    # U_0 = I, U_1 = X on |0>: A|0> = a0|0> + a1|1>, probability a0^2 + a1^2.
    u0, u1 = QuantumCircuit(1), QuantumCircuit(1)
    u1.x(0)
    alpha = [0.3, 0.7]
    assert lcu_success_probability([u0, u1], alpha) == pytest.approx(0.09 + 0.49, abs=1e-12)
    amplitudes = lcu_postselected_state([u0, u1], alpha).data
    np.testing.assert_allclose(amplitudes, np.array([0.3, 0.7]) / np.sqrt(0.58), atol=1e-10)


def test_lcu_postselection_impossible_is_refused():
    u0, u1 = QuantumCircuit(1), QuantumCircuit(1)
    u1.global_phase = np.pi  # U_1 = -I: A = 0
    assert lcu_success_probability([u0, u1], [0.5, 0.5]) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="success probability"):
        lcu_postselected_state([u0, u1], [0.5, 0.5])


def test_lcu_exact_helpers_need_bound_circuits():
    with pytest.raises(ValueError, match="unbound"):
        lcu_success_probability([pyramid(2)], [1.0])
    with pytest.raises(ValueError, match="unbound"):
        lcu_postselected_state([pyramid(2)], [1.0])
    with pytest.raises(TypeError, match="data_state"):
        lcu_success_probability([QuantumCircuit(2)], [1.0], data_state=[1, 0, 0, 0])
    with pytest.raises(ValueError, match="data_state"):
        lcu_success_probability([QuantumCircuit(2)], [1.0], Statevector.from_label("000"))


@pytest.mark.parametrize("K", [1, 2, 4])
def test_randomised_circuits_average_to_the_density_state(K):
    rng = np.random.default_rng(K)
    n = 3
    subs = make_subs(n, K, rng)
    loader = random_loader(n, rng)
    circuits = randomised_circuits(subs, loader)
    assert len(circuits) == K
    values = bind_random(subs, rng)
    x = Statevector(loader).data
    for k, (c, u) in enumerate(zip(circuits, unitaries(subs, values), strict=True)):
        assert [r.name for r in c.qregs] == ["data"]
        assert c.metadata["sub_unitary"] == k
        np.testing.assert_allclose(Statevector(bound(c, values)).data, u @ x, atol=ATOL)


# --------------------------------------------------------------------------- Fig. 13b


@settings(max_examples=12, deadline=None)
@given(
    n=st.integers(2, 4),
    K=st.integers(1, 4),
    seed=st.integers(0, 2**16),
    zeros=st.booleans(),
    start=st.integers(0, 3),
)
def test_hw_generative_reduced_state(n, K, seed, zeros, start):
    # Derivation (Supp. I.3): branch k of sum_k sqrt(alpha_k)|e_k>|0^n>: every U_j^dagger, U_j
    # pair acts on |0^n> (a phase, cancelled) or, after the CNOT fired, cancels on HW 1; only
    # block k maps |0^n> -> phase * U_k |e_s>. Tracing out the orthogonal |e_k> leaves
    # sum_k alpha_k U_k |e_s><e_s| U_k^dagger.
    start = start % n
    rng = np.random.default_rng(seed)
    subs = make_subs(n, K, rng, families=HW_FAMILIES)
    if rng.integers(2):  # HW-preserving phases: rz and rzz layers
        extra = QuantumCircuit(n)
        extra.rz(Parameter("phase_z"), 0)
        extra.rzz(Parameter("phase_zz"), 0, n - 1)
        subs[0] = subs[0].compose(extra)
    alpha = random_alpha(K, rng, zeros=zeros)
    values = bind_random(subs, rng)
    qc = hw_generative_circuit(subs, alpha, start_qubit=start)
    assert qc.count_ops()["cx"] == K
    e_s = np.zeros(2**n)
    e_s[2**start] = 1.0
    expected = mixture_of_pure(alpha, unitaries(subs, values), e_s)
    got = partial_trace(Statevector(bound(qc, values)), list(range(K))).data
    np.testing.assert_allclose(got, expected, atol=ATOL)


def test_hw_generative_refuses_non_hw_preserving():
    with pytest.raises(ValueError, match=r"sub_unitaries\[1\].*Hamming"):
        hw_generative_circuit([pyramid(3, parameter_prefix="a"), hea(3, "b")], [0.5, 0.5])
    with pytest.raises(ValueError, match="start_qubit"):
        hw_generative_circuit([pyramid(3)], [1.0], start_qubit=3)
    with pytest.raises(ValueError, match="start_qubit"):
        hw_generative_circuit([pyramid(3)], [1.0], start_qubit=-1)


# ------------------------------------------------------------------------ transpiling


def _all_builders(subs, alpha, loader):
    out = prepare_all(subs, alpha, loader)
    circuits = {"lcu": out["lcu"], "deterministic": out["deterministic"]}
    circuits.update({f"randomised_{k}": c for k, c in enumerate(out["randomised"])})
    return circuits


@pytest.mark.parametrize("level", [1, 3])
@pytest.mark.parametrize("basis", BASES, ids=["cz", "cx"])
def test_templates_transpile_and_still_match(basis, level):
    rng = np.random.default_rng(level)
    n = 3
    subs = [round_robin_layer(n, 0, "a"), hea(n, "b"), pauli_circuit(n, "c")]
    alpha = np.array([0.2, 0.5, 0.3])
    template = unary_loader_template(n)
    circuits = _all_builders(subs, alpha, template)
    hw = [pyramid(n, parameter_prefix="p"), fbs_circuit(n, "f")]
    circuits["hw_generative"] = hw_generative_circuit(hw, [0.4, 0.6], start_qubit=1)
    circuits["controlled"] = controlled_subunitary(subs[2])
    values = bind_random([*subs, *hw, template], rng)
    for name, qc in circuits.items():
        assert qc.num_parameters > 0, name
        tqc = transpile(qc, basis_gates=basis, optimization_level=level, seed_transpiler=7)
        assert set(tqc.count_ops()) <= set(basis), name
        assert {p.name for p in tqc.parameters} == {p.name for p in qc.parameters}, name
        got = Operator.from_circuit(bound(tqc, values))
        expected = Operator(bound(qc, values))
        assert got.equiv(expected, atol=1e-7), name
        assert np.allclose(got.data, expected.data, atol=1e-7), name  # global phase kept


def test_deterministic_runs_on_aer_and_samples_the_density_diagonal():
    rng = np.random.default_rng(5)
    n, K = 3, 2
    subs = [pyramid(n, parameter_prefix="a"), hea(n, "b")]
    alpha = np.array([0.35, 0.65])
    loader = unary_loader(rng.normal(size=n))
    values = bind_random(subs, rng)
    qc = bound(deterministic_circuit(subs, alpha, loader), values)
    rho = mixture_of_pure(alpha, unitaries(subs, values), Statevector(loader).data)
    probs = np.real(np.diag(rho))
    meas = QuantumCircuit(qc.num_qubits, n)
    meas.compose(qc, inplace=True)
    meas.measure(list(range(K, K + n)), list(range(n)))
    sim = AerSimulator(seed_simulator=17)
    shots = 20000
    tqc = transpile(meas, basis_gates=["cz", "rz", "sx", "x", "measure"], optimization_level=1)
    counts = sim.run(tqc, shots=shots).result().get_counts()
    freq = np.zeros(2**n)
    for key, c in counts.items():
        freq[int(key, 2)] = c / shots
    se = np.sqrt(probs * (1 - probs) / shots) + 1e-12
    assert np.all(np.abs(freq - probs) <= 5 * se + 1e-3)


def test_lcu_and_hw_generative_run_on_aer_with_the_right_statistics():
    rng = np.random.default_rng(9)
    n, K = 3, 3
    subs = [pyramid(n, parameter_prefix=f"p{k}") for k in range(K)]
    alpha = np.array([0.2, 0.3, 0.5])
    loader = unary_loader(rng.normal(size=n))
    values = bind_random(subs, rng)
    us = unitaries(subs, values)
    x = Statevector(loader).data
    ax = sum(a * u @ x for a, u in zip(alpha, us, strict=True))
    p_success = float(np.vdot(ax, ax).real)
    shots = 20000
    sim = AerSimulator(seed_simulator=23)
    basis = ["cx", "rz", "sx", "x", "measure"]

    lcu = bound(lcu_circuit(subs, alpha, loader), values)
    meas = QuantumCircuit(K + n, K)
    meas.compose(lcu, inplace=True)
    meas.measure(list(range(K)), list(range(K)))
    counts = sim.run(transpile(meas, basis_gates=basis, optimization_level=3),
                     shots=shots).result().get_counts()
    freq = counts.get("0" * K, 0) / shots
    assert abs(freq - p_success) <= 5 * np.sqrt(p_success * (1 - p_success) / shots) + 1e-3

    start = 1
    gen = bound(hw_generative_circuit(subs, alpha, start_qubit=start), values)
    meas = QuantumCircuit(K + n, n)
    meas.compose(gen, inplace=True)
    meas.measure(list(range(K, K + n)), list(range(n)))
    counts = sim.run(transpile(meas, basis_gates=basis, optimization_level=1),
                     shots=shots).result().get_counts()
    e_s = np.zeros(2**n)
    e_s[2**start] = 1.0
    probs = np.real(np.diag(mixture_of_pure(alpha, us, e_s)))
    freq = np.zeros(2**n)
    for key, c in counts.items():
        freq[int(key, 2)] = c / shots
    assert np.all(np.abs(freq - probs) <= 5 * np.sqrt(probs * (1 - probs) / shots) + 1e-3)


# ----------------------------------------------------------------------- convenience


def test_prepare_all_and_preparation_circuits():
    subs = [pyramid(3, parameter_prefix="a"), round_robin(3, parameter_prefix="b")]
    out = prepare_all(subs, [0.5, 0.5])
    assert set(out) == {"randomised", "deterministic", "lcu"}
    assert len(out["randomised"]) == 2
    prep = PreparationCircuits(subs, [0.5, 0.5])
    assert prep.num_sub_unitaries == 2 and prep.num_data_qubits == 3
    assert prep.deterministic is prep.deterministic  # built once
    assert prep.lcu.num_qubits == 5


def test_shared_parameters_are_allowed_when_the_same_objects():
    layer = pyramid(3)
    qc = deterministic_circuit([layer, layer], [0.5, 0.5])
    assert qc.num_parameters == layer.num_parameters


# ------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "builder",
    [
        lambda s, a: deterministic_circuit(s, a),
        lambda s, a: lcu_circuit(s, a),
        lambda s, a: hw_generative_circuit(s, a),
        lambda s, a: prepare_all(s, a),
        lambda s, a: randomised_circuits(s),
    ],
    ids=["deterministic", "lcu", "hw_generative", "prepare_all", "randomised"],
)
def test_bad_sub_unitaries(builder):
    with pytest.raises(ValueError, match="sub_unitaries must be a list or tuple of 1 to"):
        builder([], [])
    with pytest.raises(ValueError, match=r"sub_unitaries\[0\] has 3 .*sub_unitaries\[1\] has 4"):
        builder([pyramid(3, parameter_prefix="a"), pyramid(4, parameter_prefix="b")],
                [0.5, 0.5])
    with pytest.raises(TypeError, match=r"sub_unitaries\[1\]"):
        builder([pyramid(3), "pyramid"], [0.5, 0.5])
    with pytest.raises(TypeError, match="list or tuple"):
        builder(pyramid(3), [1.0])
    with pytest.raises(ValueError, match="same name"):
        builder([pyramid(3), pyramid(3)], [0.5, 0.5])
    measured = QuantumCircuit(3, 1)
    measured.measure(0, 0)
    with pytest.raises(ValueError, match="non-unitary"):
        builder([measured], [1.0])


@pytest.mark.parametrize(
    "builder",
    [deterministic_circuit, lcu_circuit, hw_generative_circuit, prepare_all],
)
def test_bad_alpha(builder):
    subs = [pyramid(3, parameter_prefix="a"), pyramid(3, parameter_prefix="b")]
    with pytest.raises(ValueError, match="length 2"):
        builder(subs, [0.2, 0.3, 0.5])
    with pytest.raises(ValueError, match="sum to 1"):
        builder(subs, [0.5, 0.6])
    with pytest.raises(ValueError, match="non-negative"):
        builder(subs, [1.5, -0.5])
    with pytest.raises(ValueError, match="finite"):
        builder(subs, [np.nan, 1.0])


def test_bad_loader():
    subs = [pyramid(3, parameter_prefix="a")]
    with pytest.raises(ValueError, match="loader must act on the 3 data qubits"):
        deterministic_circuit(subs, [1.0], unary_loader([1.0, 2.0]))
    with pytest.raises(TypeError, match="loader"):
        randomised_circuits(subs, loader=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="same name"):
        deterministic_circuit([pyramid(3, parameter_prefix="x")], [1.0],
                              unary_loader_template(3))
