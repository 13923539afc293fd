"""Commuting-generator gradient circuits against finite differences of exact expectations.

Oracles: ``Statevector(bound circuit).expectation_value(H)`` differentiated by central finite
differences; probabilities of the gradient circuits from ``Statevector(...).probabilities()``
(measurements removed); sampled estimates from Aer's SamplerV2 judged in standard errors.
"""

from __future__ import annotations

import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit import QuantumCircuit, transpile
from qiskit.circuit import ParameterVector
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import SparsePauliOp, Statevector
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2
from scipy.stats import norm

from qdensity.analysis import moments
from qdensity.circuits.ansatze import pairs_circuit, pyramid, round_robin_pairs
from qdensity.circuits.gates import RBSGate
from qdensity.gradients import commuting_block_gradient, commuting_blocks, commuting_gradient

FD_STEP = 1e-5
TOL = 1e-7
BASES = (["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"])


# ------------------------------------------------------------------------------------ oracles


def _bind(circuit: QuantumCircuit, values: dict) -> QuantumCircuit:
    return circuit.assign_parameters({p: values[p] for p in circuit.parameters})


def _expectation(circuit: QuantumCircuit, obs: SparsePauliOp, values: dict) -> float:
    return float(Statevector(_bind(circuit, values)).expectation_value(obs).real)


def _fd_gradient(circuit, obs, values: dict, params) -> np.ndarray:
    out = []
    for p in params:
        up, down = dict(values), dict(values)
        up[p] += FD_STEP
        down[p] -= FD_STEP
        diff = _expectation(circuit, obs, up) - _expectation(circuit, obs, down)
        out.append(diff / (2 * FD_STEP))
    return np.array(out)


def _exact_probs(measured: QuantumCircuit, values: dict) -> np.ndarray:
    bound = _bind(measured, values).remove_final_measurements(inplace=False)
    return Statevector(bound).probabilities()


def _random_values(circuit: QuantumCircuit, rng: np.random.Generator) -> dict:
    return {p: float(v) for p, v in zip(circuit.parameters, rng.uniform(-1.5, 1.5,
                                                                        circuit.num_parameters),
                                        strict=True)}


def _check_against_fd(grad, circuit, obs, rng, rows: int = 3) -> None:
    for _ in range(rows):
        values = _random_values(circuit, rng)
        probs = [_exact_probs(c, values) for c in grad.circuits]
        got = grad.gradient_from_probabilities(probs)
        want = _fd_gradient(circuit, obs, values, grad.parameters)
        np.testing.assert_allclose(got, want, atol=TOL, rtol=0)


# ---------------------------------------------------------------------------------- circuits


def _unary_loader(n: int) -> QuantumCircuit:
    """Dense unary state: X on qubit 0, then a chain of data RBS gates (angles x)."""
    x = ParameterVector("x", n - 1)
    qc = QuantumCircuit(n)
    qc.x(0)
    for k in range(n - 1):
        qc.append(RBSGate(x[k]), [k, k + 1])
    return qc


def _z_sum(n: int, coeffs) -> SparsePauliOp:
    return SparsePauliOp.from_sparse_list([("Z", [i], c) for i, c in enumerate(coeffs)], n)


def _hwe_layer(n: int) -> QuantumCircuit:
    x = ParameterVector("x", 2 * n)
    th = ParameterVector("θ", n)
    qc = QuantumCircuit(n)
    for i in range(n):
        qc.ry(x[i], i)
        qc.rz(x[n + i], i)
    for i in range(n):
        qc.ry(th[i], i)
    for i in range(n - 1):
        qc.cx(i, i + 1)
    return qc


def _xx_equivariant(n: int) -> QuantumCircuit:
    """Ry angle encoding, then translation-symmetric X-string evolutions (shared parameters)."""
    x = ParameterVector("x", n)
    th = ParameterVector("θ", 3)
    qc = QuantumCircuit(n)
    for i in range(n):
        qc.ry(x[i], i)
    sym_x = SparsePauliOp.from_sparse_list([("X", [i], 1.0) for i in range(n)], n)
    qc.append(PauliEvolutionGate(sym_x, th[0]), range(n))
    for i in range(n):  # sym(X_1 X_2): one gate per ring edge, all sharing theta_1
        qc.append(PauliEvolutionGate(SparsePauliOp("XX"), th[1]), [i, (i + 1) % n])
    for i in range(n):  # sym(X_1 X_2 X_3) with angle 2 theta_2 (a coefficient a = 2)
        qc.append(
            PauliEvolutionGate(SparsePauliOp("XXX"), 2 * th[2]), [i, (i + 1) % n, (i + 2) % n]
        )
    return qc


# ------------------------------------------------------------------------------ single block


@pytest.mark.parametrize("n", [4, 5])
@pytest.mark.parametrize("diagonaliser", ["rbs", "clifford"])
def test_round_robin_moment(n, diagonaliser):
    rng = np.random.default_rng(n)
    qc = _unary_loader(n).compose(pairs_circuit(n, [round_robin_pairs(n)[1]]))
    observables = [_z_sum(n, np.eye(n)[i]) for i in range(n)] + [
        _z_sum(n, rng.normal(size=n))
    ]
    for obs in observables:
        grad = commuting_gradient(qc, obs, diagonaliser=diagonaliser)
        assert grad.num_gradient_circuits == 1
        assert grad.diagonaliser == diagonaliser
        assert [p.name for p in grad.parameters] == [p.name for p in qc.parameters
                                                     if p.name.startswith("θ")]
        assert set(grad.circuit.parameters) == set(qc.parameters)
        _check_against_fd(grad, qc, obs, rng, rows=2)


def test_rbs_layer_is_preferred_automatically():
    n = 4
    qc = _unary_loader(n).compose(pairs_circuit(n, [round_robin_pairs(n)[0]]))
    grad = commuting_gradient(qc, _z_sum(n, [1.0, 0, 0, 0]))
    assert grad.diagonaliser == "rbs"
    assert grad.diagonalising_circuits[0].count_ops() == {"rbs": n // 2}


@pytest.mark.parametrize("diagonaliser", ["auto", "clifford"])
def test_pyramid_even_moments_one_circuit(diagonaliser):
    n = 5
    pyr = pyramid(n)
    sub = QuantumCircuit(n)
    for t, layer in enumerate(moments(pyr)):
        if t % 2 == 0:
            for inst in layer:
                sub.append(inst.operation, [pyr.find_bit(q).index for q in inst.qubits])
    qc = _unary_loader(n).compose(sub)
    rng = np.random.default_rng(11)
    obs = _z_sum(n, rng.normal(size=n))
    grad = commuting_gradient(qc, obs, diagonaliser=diagonaliser)
    assert grad.num_gradient_circuits == 1
    assert len(grad.parameters) == sub.num_parameters > 4  # repeated pairs, separate angles
    _check_against_fd(grad, qc, obs, rng)


@pytest.mark.parametrize("which", ["sum_z", "z0z1"])
def test_hardware_efficient_layer(which):
    n = 4
    qc = _hwe_layer(n)
    obs = (
        _z_sum(n, np.ones(n))
        if which == "sum_z"
        else SparsePauliOp.from_sparse_list([("ZZ", [0, 1], 1.0)], n)
    )
    grad = commuting_gradient(qc, obs)
    assert grad.diagonaliser == "clifford"
    if which == "z0z1":
        assert grad.num_gradient_circuits == 1
    assert grad.num_gradient_circuits <= n
    assert len(grad.circuits) == len(grad.term_groups) == grad.num_gradient_circuits
    _check_against_fd(grad, qc, obs, np.random.default_rng(5))


def test_xx_equivariant_circuit():
    n = 4
    qc = _xx_equivariant(n)
    obs = _z_sum(n, np.ones(n))
    grad = commuting_gradient(qc, obs)
    assert len(grad.parameters) == 3
    assert grad.num_gradient_circuits <= n
    _check_against_fd(grad, qc, obs, np.random.default_rng(9), rows=2)


def test_gradient_circuits_transpile_and_run():
    n = 4
    moment = pairs_circuit(n, [round_robin_pairs(n)[0]])
    cases = [
        (_unary_loader(n).compose(moment), _z_sum(n, [1, 0, 0, 0])),
        (_hwe_layer(n), _z_sum(n, np.ones(n))),
        (_xx_equivariant(n), _z_sum(n, np.ones(n))),
    ]
    rng = np.random.default_rng(0)
    for qc, obs in cases:
        grad = commuting_gradient(qc, obs)
        for circ in grad.circuits:
            bound = _bind(circ, _random_values(circ, rng))
            for basis in BASES:
                tq = transpile(bound, basis_gates=basis, optimization_level=1, seed_transpiler=1)
                assert set(tq.count_ops()) <= set(basis) | {"measure", "barrier"}
                res = AerSimulator(seed_simulator=1).run(tq, shots=8).result()
                assert sum(res.get_counts().values()) == 8


def test_measured_register_layout():
    n = 3
    qc = _unary_loader(n).compose(pairs_circuit(n, [[(0, 1)]]))
    circ = commuting_gradient(qc, _z_sum(n, [1, 0, 0])).circuit
    assert [r.name for r in circ.cregs] == ["meas"] and circ.num_clbits == n
    measures = [i for i in circ.data if i.operation.name == "measure"]
    assert [(circ.find_bit(i.qubits[0]).index, circ.find_bit(i.clbits[0]).index)
            for i in measures] == [(j, j) for j in range(n)]


# ------------------------------------------------------------------------------ error cases


def test_non_commuting_block_names_both_gates():
    qc = pairs_circuit(3, [[(0, 1)], [(1, 2)]])
    with pytest.raises(ValueError, match=r"rbs\(θ\[0\]\) on qubits \(0, 1\).*rbs\(θ\[1\]\) on "
                                         r"qubits \(1, 2\)"):
        commuting_gradient(qc, _z_sum(3, [1, 0, 0]))


def test_observable_errors():
    qc = pairs_circuit(3, [[(0, 1)]])
    with pytest.raises(ValueError, match="observable acts on 2 qubits but the circuit has 3"):
        commuting_gradient(qc, SparsePauliOp("ZI"))
    with pytest.raises(ValueError, match="Hermitian"):
        commuting_gradient(qc, SparsePauliOp(["ZII"], [1j]))
    with pytest.raises(TypeError, match="SparsePauliOp"):
        commuting_gradient(qc, "ZII")


def test_other_input_errors():
    n = 4
    qc = _hwe_layer(n)
    with pytest.raises(ValueError, match="diagonaliser='rbs'"):
        commuting_gradient(qc, _z_sum(n, np.ones(n)), diagonaliser="rbs")
    with pytest.raises(ValueError, match="diagonaliser must be"):
        commuting_gradient(qc, _z_sum(n, np.ones(n)), diagonaliser="magic")
    reupload = _hwe_layer(n)
    data_param = next(p for p in reupload.parameters if p.name.startswith("x"))
    reupload.ry(data_param, 0)  # data gate after trainable gates
    with pytest.raises(ValueError, match="neither trainable nor Clifford"):
        commuting_gradient(reupload, _z_sum(n, np.ones(n)))
    grad = commuting_gradient(pairs_circuit(2, [[(0, 1)]]), _z_sum(2, [1, 0]))
    with pytest.raises(ValueError, match=r"shape \(4,\) or \(rows, 4\)"):
        grad.gradient_from_probabilities(np.ones((2, 8)) / 8)
    with pytest.raises(ValueError, match="sum to 1"):
        grad.gradient_from_probabilities(np.ones(4))
    with pytest.raises(ValueError, match="shots must be >= 2"):
        grad.standard_error(np.ones(4) / 4, 1)
    measured = pairs_circuit(2, [[(0, 1)]])
    measured.measure_all()
    with pytest.raises(ValueError, match="no classical bits"):
        commuting_gradient(measured, _z_sum(2, [1, 0]))


# ------------------------------------------------------------------------------ multi-block


def _per_block(method: str) -> int:
    """Circuits per earlier block and Pauli term: two observable shifts, or one Hadamard test."""
    return 2 if method == "shift" else 1


@pytest.mark.parametrize("method", ["shift", "hadamard"])
@pytest.mark.parametrize("coeffs", [[1.0, 0, 0, 0], [1.0, 0, -0.5, 0.3]])
def test_pyramid_multi_block(coeffs, method):
    n = 4
    qc = _unary_loader(n).compose(pyramid(n))
    obs = _z_sum(n, coeffs)
    blocks = commuting_blocks(qc)
    grad = commuting_block_gradient(qc, obs, method=method)
    terms = sum(1 for c in coeffs if c)
    assert grad.blocks == blocks and len(blocks) == 2 * n - 3 and grad.method == method
    earlier = _per_block(method) * terms * (len(blocks) - 1)
    assert grad.num_gradient_circuits == len(grad.circuits) == earlier + 1
    tag = "observable shift" if method == "shift" else "Hadamard"
    assert sum(tag in r for r in grad.roles) == earlier
    width = n if method == "shift" else n + 1
    assert all(c.num_qubits == width for c, r in zip(grad.circuits, grad.roles, strict=True)
               if tag in r)
    _check_against_fd(grad, qc, obs, np.random.default_rng(2), rows=2)
    block_circ = grad.circuits[0]
    bound = _bind(block_circ, _random_values(block_circ, np.random.default_rng(0)))
    for basis in BASES:
        tq = transpile(bound, basis_gates=basis, optimization_level=1, seed_transpiler=1)
        assert set(tq.count_ops()) <= set(basis) | {"measure", "barrier"}


@pytest.mark.parametrize("n", [3, 4, 5])
def test_cor2_count_for_a_pauli_observable(n):
    """Paper Cor. 2: B commuting blocks and a Pauli observable need 2B - 1 circuits, no ancilla."""
    qc = _unary_loader(n).compose(pyramid(n))
    obs = SparsePauliOp.from_sparse_list([("Z", [n - 1], 1.0)], n)
    grad = commuting_block_gradient(qc, obs)
    num_blocks = len(grad.blocks)
    assert num_blocks == 2 * n - 3
    assert grad.num_gradient_circuits == 2 * num_blocks - 1
    assert all(c.num_qubits == n for c in grad.circuits)
    assert commuting_block_gradient(qc, obs, method="hadamard").num_gradient_circuits == num_blocks
    if n == 3:
        _check_against_fd(grad, qc, obs, np.random.default_rng(7), rows=2)


@pytest.mark.parametrize("method", ["shift", "hadamard"])
@pytest.mark.parametrize("trailing_data_gate", [False, True])
def test_multi_block_general_pauli_observable(trailing_data_gate, method):
    n = 3
    qc = _unary_loader(n).compose(pyramid(n))
    if trailing_data_gate:  # a fixed non-Clifford gate after the last block: measured through W
        qc.ry(next(p for p in qc.parameters if p.name.startswith("x")), 1)
    obs = SparsePauliOp(["XYZ", "YYI", "ZIX"], [0.5, -1.0, 0.3])
    grad = commuting_block_gradient(qc, obs, method=method)
    through_w = sum("direct" not in r for r in grad.roles)
    assert through_w == _per_block(method) * 3 * (3 if trailing_data_gate else 2)
    _check_against_fd(grad, qc, obs, np.random.default_rng(3), rows=2)


@pytest.mark.parametrize("method", ["shift", "hadamard"])
def test_two_hwe_layers_and_reuploading(method):
    """The fixed Clifford gates closing the circuit (CZ ladder, SWAP) are absorbed into the
    Pauli string, not run forwards and backwards; finite differences check the absorption."""
    n = 3
    x = ParameterVector("x", n)
    a, b = ParameterVector("a", n), ParameterVector("b", n)
    qc = QuantumCircuit(n)
    for i in range(n):
        qc.ry(x[i], i)
    for i in range(n):
        qc.ry(a[i], i)
    for i in range(n - 1):
        qc.cx(i, i + 1)
    for i in range(n):
        qc.rz(x[i], i)  # data re-uploading: not Clifford, closes the block
    for i in range(n):
        qc.rx(b[i], i)
    for i in range(n - 1):
        qc.cz(i, i + 1)
    qc.swap(0, 2)
    obs = SparsePauliOp.from_sparse_list([("ZZ", [0, 2], 1.0), ("X", [1], 0.5)], n)
    grad = commuting_block_gradient(qc, obs, method=method)
    assert len(grad.blocks) == 2
    through_w = [c for c, r in zip(grad.circuits, grad.roles, strict=True) if "direct" not in r]
    assert len(through_w) == _per_block(method) * 2  # block 0, two Pauli terms
    assert all("swap" not in c.count_ops() for c in through_w)  # absorbed into P_t
    _check_against_fd(grad, qc, obs, np.random.default_rng(4), rows=2)
    for circ in grad.circuits:
        bound = _bind(circ, _random_values(circ, np.random.default_rng(1)))
        for basis in BASES:
            tq = transpile(bound, basis_gates=basis, optimization_level=1, seed_transpiler=1)
            assert set(tq.count_ops()) <= set(basis) | {"measure", "barrier"}


@pytest.mark.parametrize("method", ["shift", "hadamard"])
def test_explicit_blocks_and_shared_parameter(method):
    n = 3
    t = ParameterVector("θ", 2)
    qc = _unary_loader(n)
    qc.append(RBSGate(t[0]), [0, 1])
    qc.append(RBSGate(t[1]), [1, 2])
    qc.append(RBSGate(t[0]), [0, 1])  # theta_0 shared across two blocks
    obs = _z_sum(n, [1.0, 0.0, 0.0])
    start = len(_unary_loader(n).data)
    blocks = [(start, start + 1), (start + 1, start + 2), (start + 2, start + 3)]
    grad = commuting_block_gradient(qc, obs, blocks=blocks, method=method)
    assert grad.blocks == blocks and grad.num_gradient_circuits == (5 if method == "shift" else 3)
    _check_against_fd(grad, qc, obs, np.random.default_rng(6))
    with pytest.raises(ValueError, match="lies in no block"):
        commuting_block_gradient(qc, obs, blocks=blocks[:2])
    with pytest.raises(ValueError, match="do not commute"):
        commuting_block_gradient(qc, obs, blocks=[(start, start + 3)])
    with pytest.raises(ValueError, match=r"method must be one of 'shift', 'hadamard'"):
        commuting_block_gradient(qc, obs, method="parameter_shift")
    with pytest.raises(ValueError, match="observable acts on|qubits"):
        commuting_block_gradient(qc, _z_sum(n + 1, [1.0] + [0.0] * n))


# ------------------------------------------------------------------------------------ sampled


def _sampled_probs(circuit: QuantumCircuit, rows: np.ndarray, shots: int, seed: int) -> np.ndarray:
    tq = transpile(circuit, basis_gates=BASES[1], optimization_level=1, seed_transpiler=seed)
    assert list(tq.parameters) == list(circuit.parameters)
    sampler = SamplerV2(seed=seed)
    bits = sampler.run([(tq, rows)], shots=shots).result()[0].data.meas
    dim = 2**circuit.num_qubits
    out = np.zeros((rows.shape[0], dim))
    for r in range(rows.shape[0]):
        for k, c in bits.get_int_counts(loc=r).items():
            out[r, k] = c / shots
    return out



def _estimator_moments(exact, values, shots):
    """Exact variance of the gradient estimate, and the two parts of the estimated ``se**2``'s
    error, from the exact outcome probabilities of every circuit; plus the Wilson term.

    Per circuit with per-shot values ``v`` (outcome x parameter), probabilities ``e`` and
    ``N`` shots, the unbiased sample variance is ``s^2 = (sum (x - mu)^2 - N (xbar - mu)^2) /
    (N - 1)``: its first part is a mean of ``N`` terms of variance ``m4 - m2^2`` (``m2``,
    ``m4``: central moments), normal for large effective counts; its second part is at most
    ``z^2 m2 / (N - 1)`` when ``|xbar - mu| <= z sigma / sqrt(N)``. ``se^2`` adds ``s^2 / N``
    over the independent circuits.
    """
    var = normal_var = mean_scale = wilson = 0.0
    n = float(shots)
    for e, v in zip(exact, values, strict=True):
        mu = e @ v
        m2 = np.maximum(e @ v**2 - mu**2, 0.0)
        m4 = e @ v**4 - 4 * mu * (e @ v**3) + 6 * mu**2 * (e @ v**2) - 3 * mu**4
        var = var + m2 / n
        normal_var = normal_var + np.maximum(m4 - m2**2, 0.0) * n / (n - 1) ** 2 / n**2
        mean_scale = mean_scale + m2 / (n - 1) / n
        width = v.max(axis=0) - v.min(axis=0)
        wilson = wilson + width**2 / (4 * n**2)
    return var, normal_var, mean_scale, wilson


@pytest.mark.parametrize("case", ["round_robin", "hwe", "pyramid_blocks"])
def test_sampled_gradients_within_standard_errors(case):
    n = 4
    if case == "round_robin":
        qc = _unary_loader(n).compose(pairs_circuit(n, [round_robin_pairs(n)[1]]))
        obs = _z_sum(n, [1.0, -0.5, 0.25, 0.8])
    elif case == "hwe":
        qc = _hwe_layer(n)
        obs = SparsePauliOp.from_sparse_list([("ZZ", [0, 1], 1.0), ("Z", [3], 0.7)], n)
    else:  # five commuting blocks, observable shifts (Cor. 2): 2B - 1 = 9 circuits
        qc = _unary_loader(n).compose(pyramid(n))
        obs = _z_sum(n, [0.0, 0.0, 0.0, 1.0])
    if case == "pyramid_blocks":
        grad = commuting_block_gradient(qc, obs)
        assert grad.num_gradient_circuits == 9
    else:
        grad = commuting_gradient(qc, obs)
    rng = np.random.default_rng(21)
    rows = rng.uniform(-1.5, 1.5, size=(4, qc.num_parameters))
    shots = 4000
    sampled, exact = [], []
    for c, circ in enumerate(grad.circuits):
        sampled.append(_sampled_probs(circ, rows, shots, seed=_stat_seed(100) + c))
        exact.append(
            np.array([_exact_probs(circ, dict(zip(circ.parameters, r, strict=True))) for r in rows])
        )
    est = grad.gradient_from_probabilities(sampled)
    true = grad.gradient_from_probabilities(exact)
    se = grad.standard_error(sampled, shots)
    true_var, normal_var, mean_scale, wilson = _estimator_moments(
        exact, grad.value_matrices(), shots)
    true_se = np.sqrt(true_var)
    informative = true_se > 1e-3  # parameters whose estimator is not constant
    assert informative.sum() >= 4
    # Both checks hold with probability >= 1 - 1e-3 for any seed (Bonferroni: 5e-4 each,
    # spread over the m checked entries and, for the sample means, over the circuits). The
    # estimate is a sum of 4000-shot means, normal well within this rate. The variance
    # estimate (see _estimator_moments) is checked where its normal part is precise (relative
    # spread below 10%, an effective count above ~100: sparse outcomes make it a skewed,
    # Poisson-like count), with the sample-mean part bounded one-sidedly; a plain normal bound
    # on the whole failed 2 of 50 seed sets (near-symmetric two-point values put chi-square(1)
    # tails on it).
    m = int(informative.sum())
    z = float(norm.isf(5e-4 / (2 * m)))
    z_mean = float(norm.isf(5e-4 / (2 * m * len(grad.circuits))))
    assert np.all(np.abs(est - true)[informative] <= z * true_se[informative])
    expected_se2 = true_var + wilson  # unbiased s^2 / N plus the Wilson term R^2 / (4 N^2)
    precise = informative & (np.sqrt(normal_var) < 0.1 * expected_se2)
    assert precise.sum() >= 2
    diff = (se**2 - expected_se2)[precise]
    high = z * np.sqrt(normal_var)[precise] + mean_scale[precise]
    low = z * np.sqrt(normal_var)[precise] + z_mean**2 * mean_scale[precise]
    assert np.all((diff <= high) & (diff >= -low))
    # exact gradient itself against finite differences for the first row
    vals = dict(zip(qc.parameters, rows[0], strict=True))
    np.testing.assert_allclose(true[0], _fd_gradient(qc, obs, vals, grad.parameters), atol=TOL)


def test_grouping_names_the_anticommuting_gradient_strings_and_sorts_like_labels():
    """The grouping works on string rows; its error names the two strings by label, and a
    group's distinct strings come out in the order of ``sorted(set(labels))``."""
    from types import SimpleNamespace

    from qiskit.quantum_info import PauliList

    from qdensity.gradients._direct import _distinct_in_label_order, _group_terms

    paulis = PauliList(["XZI", "ZZI", "IYX", "XZI", "IIZ", "YII"])
    gate = SimpleNamespace(label="rx[0]", parameter="a")
    with pytest.raises(ValueError, match="XZI from .* anticommutes with ZZI from"):
        _group_terms((paulis, [("ZII", {}, [(0, gate), (1, gate)])]), [])
    rows = [0, 1, 2, 3, 4, 5, 2]
    got = _distinct_in_label_order(paulis, rows).to_labels()
    assert got == sorted(set(paulis[rows].to_labels()))
