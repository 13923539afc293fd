"""The pieces that make density-gradient plans scale (issue 32, item 4), against independent
oracles: the layer conjugation against dense operators, the packed GF(2) product against an
integer matrix product, and the unary-readout commuting Jacobians of the round-robin model
(one estimator table per output, read off one circuit) against central finite differences of
Qiskit ``Statevector`` probabilities."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter
from qiskit.quantum_info import Operator, PauliList, SparsePauliOp, Statevector

from qdensity import DensityQNN, Encoding, by_moments
from qdensity.analysis._conjugate import conjugate_by_layer
from qdensity.analysis._gf2 import anticommutation
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.gates import RBSGate, rbs_matrix
from qdensity.execution.statevector.adjoint import AdjointEngine
from qdensity.gradients import density_gradient_plan

RNG = np.random.default_rng(32)


def _random_paulis(m: int, n: int, density: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    return RNG.random((m, n)) < density, RNG.random((m, n)) < density


@pytest.mark.parametrize("m, k, n", [(1, 1, 1), (7, 5, 3), (40, 33, 70), (0, 3, 4), (130, 2, 129)])
def test_packed_anticommutation_equals_the_integer_product(m, k, n):
    xa, za = _random_paulis(m, n)
    xb, zb = _random_paulis(k, n)
    want = ((xa.astype(int) @ zb.T.astype(int) + za.astype(int) @ xb.T.astype(int)) % 2) == 1
    got = anticommutation(xa, za, xb, zb)
    assert got.shape == (m, k) and got.dtype == bool
    np.testing.assert_array_equal(got, want)
    self_want = ((xa.astype(int) @ za.T.astype(int) + za.astype(int) @ xa.T.astype(int))
                 % 2) == 1
    np.testing.assert_array_equal(anticommutation(xa, za), self_want)


@pytest.mark.parametrize("pairs", [[(0, 1), (2, 4)], [(3, 0)], [(1, 2), (4, 3), (0, 5)]])
def test_layer_conjugation_equals_the_dense_operator(pairs):
    n = 6
    x, z = _random_paulis(12, n, 0.5)
    coeffs = RNG.normal(size=12) + 1j * RNG.normal(size=12)
    before = SparsePauliOp(PauliList.from_symplectic(z, x), coeffs)
    layer = QuantumCircuit(n)
    for i, j in pairs:
        layer.append(RBSGate(np.pi / 4), [i, j])
    u = Operator(layer).data
    want = u @ before.to_matrix() @ u.conj().T
    ox, oz, oc, src = conjugate_by_layer(x, z, coeffs, rbs_matrix(np.pi / 4), np.array(pairs))
    assert src.shape == oc.shape and src.max() < 12
    after = SparsePauliOp(PauliList.from_symplectic(oz, ox), oc)
    np.testing.assert_allclose(after.to_matrix(), want, atol=1e-12)


def _unary_probabilities(circuit, row) -> np.ndarray:
    probs = Statevector(circuit.assign_parameters(row)).probabilities()
    return probs[1 << np.arange(circuit.num_qubits)]


@pytest.mark.parametrize("n", [4, 7])
def test_round_robin_unary_jacobians_match_finite_differences(n):
    """Every sub-unitary (one round-robin moment) read out as n unary probabilities: the
    plan's commuting Jacobians (one circuit per sub-unitary, one table per output) against
    central differences (step 1e-5: error ~1e-10 + rounding 1e-11) of exact probabilities."""
    subs = by_moments(round_robin(n)).sub_unitaries
    _check_unary_jacobians(subs, n)


def test_mixed_rbs_moments_unary_jacobians_match_finite_differences():
    """One moment of RBS gates on disjoint pairs in either orientation, an angle ``2 b``, a
    parameter shared by two gates of one moment and an idle qubit (its output has no
    gradient): the per-pair tables (one template per distinct gate) against central
    differences of exact probabilities."""
    a, b, c = Parameter("a"), Parameter("b"), Parameter("c")
    one, two = QuantumCircuit(5), QuantumCircuit(5)
    one.append(RBSGate(a), [0, 3])
    one.append(RBSGate(2 * b), [4, 1])
    two.append(RBSGate(c), [2, 1])
    two.append(RBSGate(c), [3, 0])
    _check_unary_jacobians([one, two], 5)


def test_two_rbs_gates_on_one_pair_unary_jacobians_match_finite_differences():
    """Two RBS gates on each of two pairs in one commuting block (a butterfly-like layer: the
    gates of one pair commute), so the block has fewer pairs than gates: the per-pair tables do
    not apply and the general path answers, against central differences."""
    a, b, c, d = (Parameter(s) for s in "abcd")
    sub = QuantumCircuit(4)
    sub.append(RBSGate(a), [0, 1])
    sub.append(RBSGate(b), [2, 3])
    sub.append(RBSGate(c), [0, 1])
    sub.append(RBSGate(d), [2, 3])
    _check_unary_jacobians([sub], 4, per_moment=False)


def _check_unary_jacobians(subs, n, per_moment=True):
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=3)
    X = RNG.normal(size=(2, n))
    plan = density_gradient_plan(model, X, method="commuting")
    if per_moment:
        assert plan.meta["gradient_circuits"] == len(subs)  # one per moment
    grad = plan.run(AdjointEngine())
    eps = 1e-5
    for k in range(model.num_subunitaries):
        circ = model.circuit(k)
        rows = model.rows(k, X)
        own = set(model.sub_unitaries[k].parameters)
        cols = [i for i, p in enumerate(circ.parameters) if p in own]
        assert grad.jacobians[k].shape[-1] == len(cols) > 0
        for b in range(rows.shape[0]):
            np.testing.assert_allclose(grad.outputs[b, k], _unary_probabilities(circ, rows[b]),
                                       atol=1e-10)
            for c, col in enumerate(cols):
                up, down = rows[b].copy(), rows[b].copy()
                up[col] += eps
                down[col] -= eps
                fd = (_unary_probabilities(circ, up) - _unary_probabilities(circ, down)) / (
                    2 * eps)
                np.testing.assert_allclose(grad.jacobians[k][b, :, c], fd, atol=1e-8)


def test_analyses_are_kept_outside_the_model_and_shared_by_equal_structures():
    n = 4
    subs = by_moments(round_robin(n)).sub_unitaries
    one = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    two = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=1)
    from qdensity.gradients import _analysis

    X = RNG.normal(size=(1, n))
    _analysis._CACHE.clear()
    density_gradient_plan(one, X, method="commuting")
    first = dict(_analysis._CACHE)
    assert len(first) == one.num_subunitaries  # one analysis per sub-unitary structure
    density_gradient_plan(two, X, method="commuting")
    assert not any("cache" in key for key in vars(one))
    # the second model's analyses are the first's (derived once per structure), and they
    # hold no gradient circuit (the jobs build theirs on read)
    assert len(_analysis._CACHE) == len(first)
    assert all(_analysis._CACHE[key] is hit for key, hit in first.items())
    assert all(not shared.circuits for shared, _ in first.values())


def test_raw_shot_estimates_on_distinct_outcomes_equal_the_per_shot_mean_and_variance():
    # gradient_from_bits reads each row's distinct outcomes with their counts: the mean and the
    # unbiased variance must be those of the per-shot values, computed here shot by shot
    from qdensity.analysis.pauli import ZStringTable
    from qdensity.gradients._circuits import _raw_mean

    rng = np.random.default_rng(7)
    n, P = 6, 3
    z = rng.integers(0, 2, size=(5, n)).astype(bool)
    table = ZStringTable(z, rng.normal(size=(5, P)))
    outcomes = rng.integers(0, 2, size=(4, n)).astype(bool)  # few distinct outcomes, like HW-1
    bits = outcomes[rng.integers(0, 4, size=(3, 200))]  # (rows, shots, n)
    per_shot = np.array([[[sum(table.coefficients[t, p] * (-1) ** int(np.sum(b & z[t]))
                                for t in range(5)) for p in range(P)] for b in row]
                         for row in bits])
    mean, se = _raw_mean(table, bits)
    np.testing.assert_allclose(mean, per_shot.mean(axis=1), atol=1e-12)
    var = per_shot.var(axis=1, ddof=1)
    R = table.value_range()
    np.testing.assert_allclose(se, np.sqrt(var / 200 + R**2 / (4 * 200**2)), atol=1e-12)


def test_compact_output_stack_estimates_equal_the_per_shot_mean_and_variance():
    """The round-robin moment's outputs kept as one compact stack (no table per output): the
    sampled estimates read off the stack by its nonzeros equal, for every output and
    parameter, the mean and unbiased variance of the per-shot values of the output's own
    table (materialised from the stack), computed shot by shot."""
    from qdensity.execution.job_results import JobResult
    from qdensity.gradients._circuits import gradients_from_results
    from qdensity.gradients._outputs import OutputGradients
    from qdensity.gradients.density import _circuit_of, _commuting_analysis

    n, rows, shots = 6, 2, 150
    subs = by_moments(round_robin(n)).sub_unitaries
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=1)
    circ, params = _circuit_of(model, 2)
    _, grads = _commuting_analysis(model, circ, params, 2)
    assert isinstance(grads, OutputGradients) and len(grads) == n
    rng = np.random.default_rng(5)
    # weight-1 shots plus a few readout-like flips: parities of one and two set bits
    bits = np.zeros((rows, shots, n), dtype=bool)
    bits[np.arange(rows)[:, None], np.arange(shots)[None, :],
         rng.integers(0, n, size=(rows, shots))] = True
    bits ^= rng.random((rows, shots, n)) < 0.05
    mean, se = gradients_from_results(grads, [JobResult(None, shots, None, bits=bits)])
    P = len(params)
    assert mean.shape == se.shape == (rows, n, P)
    for o in range(n):
        (table,) = grads[o]._values
        per_shot = np.array([[[sum(table.coefficients[t, p]
                                   * (-1) ** int(np.sum(b & table.z[t]))
                                   for t in range(table.z.shape[0])) for p in range(P)]
                               for b in row] for row in bits])
        np.testing.assert_allclose(mean[:, o], per_shot.mean(axis=1), atol=1e-12)
        R = table.value_range()
        var = per_shot.var(axis=1, ddof=1)
        np.testing.assert_allclose(se[:, o], np.sqrt(var / shots + R**2 / (4 * shots**2)),
                                   atol=1e-12)


def _variants() -> list[QuantumCircuit]:
    """Circuits that differ from each other in one structural item each, and rebuilt twins."""
    theta, phi = Parameter("θ"), Parameter("φ")
    out = []
    for _build in range(2):  # every variant twice: equal structure, distinct objects
        for pairs, angles, extra in [([(0, 1), (1, 2)], (theta, phi), None),
                                     ([(1, 0), (1, 2)], (theta, phi), None),  # qubit order
                                     ([(0, 1), (1, 2)], (phi, theta), None),  # parameters
                                     ([(0, 1), (1, 2)], (theta, 2 * phi), None),  # expression
                                     ([(0, 1), (1, 2)], (theta, 0.25), None),  # a number
                                     ([(0, 1), (1, 2)], (theta, phi), "x"),  # one more gate
                                     ([(0, 1)], (theta,), None)]:
            qc = QuantumCircuit(3)
            for pair, angle in zip(pairs, angles, strict=True):
                qc.append(RBSGate(angle), pair)
            if extra:
                qc.x(2)
            out.append(qc)
    return out


def test_circuit_digest_is_equal_exactly_when_the_fingerprint_is():
    from qdensity.execution._compile import circuit_digest, circuit_fingerprint

    circuits = _variants()
    for a in circuits:
        assert len(circuit_digest(a)) == 32
        for b in circuits:
            assert (circuit_digest(a) == circuit_digest(b)) == (
                circuit_fingerprint(a) == circuit_fingerprint(b))
    assert len({circuit_fingerprint(c) for c in circuits}) == len(circuits) // 2


def test_analysis_keys_are_digests_not_gate_tuples():
    from qdensity.gradients import _analysis

    n = 6
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       readout="unary_probabilities", seed=0)
    _analysis._CACHE.clear()
    density_gradient_plan(model, RNG.normal(size=(1, n)), method="commuting", shots=10)
    for kind, fingerprint, params, _ in _analysis._CACHE:
        assert kind == "commuting" and fingerprint[0] == "encoded"
        assert all(isinstance(part, bytes) and len(part) == 32 for part in fingerprint[1:])
        assert len(params) == n // 2


def test_forward_stack_equals_numpy_stack_of_the_plans_estimates():
    from qdensity.execution.plans import Estimate, Plan
    from qdensity.gradients.density import _forward_stack

    fwd = [Estimate(RNG.normal(size=(3, 5)), RNG.random((3, 5))) for _ in range(4)]
    fwd[2] = Estimate(fwd[2].value.astype(np.float32), fwd[2].standard_error)  # promoted
    plans = [Plan([], lambda r, f=f: f) for f in fwd]
    outputs, errors = _forward_stack(plans, [0, 0, 0, 0, 0], [])
    for got, want in ((outputs, np.stack([f.value for f in fwd], axis=1)),
                      (errors, np.stack([f.standard_error for f in fwd], axis=1))):
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    with pytest.raises(ValueError, match="shape"):
        _forward_stack([plans[0], Plan([], lambda r: Estimate(np.zeros((3, 4)),
                                                              np.zeros((3, 4))))],
                       [0, 0, 0], [])


def test_a_sampled_plan_leaves_no_garbage_circuit_holding_instructions():
    """The plan's views of ``V(x) U_k`` are cleared once read (a QuantumCircuit is a
    reference cycle, so they would hold their instructions until the next collection); the
    model's own circuits are untouched and the jobs still build their circuits."""
    import gc

    n = 6
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       readout="unary_probabilities", seed=0)
    sizes = [len(c.data) for c in (model.encoding.circuit, *model.sub_unitaries)]
    gc.collect()
    # circuits of earlier tests that a cache lets go during the plan are garbage too (in a
    # random test order): only circuits made by the plan are its views. type(), not
    # isinstance: isinstance reads __class__, which warns on torch's deprecated module proxies
    before = {id(o) for o in gc.get_objects() if issubclass(type(o), QuantumCircuit)}
    was = gc.isenabled()
    gc.disable()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        plan = density_gradient_plan(model, RNG.normal(size=(2, n)), method="commuting",
                                     shots=10)
        gc.collect()
        left = [o for o in gc.garbage
                if issubclass(type(o), QuantumCircuit) and id(o) not in before]
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        if was:
            gc.enable()
    assert left and all(len(c.data) == 0 for c in left)
    assert [len(c.data) for c in (model.encoding.circuit, *model.sub_unitaries)] == sizes
    assert all(len(job.circuit.data) > sizes[0] for job in plan.jobs)


def test_the_plan_collects_its_views_while_building():
    """The cleared views are collected every 16 sub-unitaries (while young), not all left to
    the end of the build: of 17, at least 15 are collected during it (none without the
    collections: all 17 wait for the end). Every circuit alive before the plan is held here, so
    an earlier test's circuit that a cache lets go (in a random test order) cannot become
    garbage, and the plan is held, so only its temporaries can; of those, the views are the
    emptied ones."""
    import gc

    n = 18  # 17 round-robin moments
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       readout="unary_probabilities", seed=0)
    gc.collect()
    held = [o for o in gc.get_objects() if issubclass(type(o), QuantumCircuit)]

    def views() -> int:
        return sum(issubclass(type(o), QuantumCircuit) and o.num_qubits == n and not o.data
                   for o in gc.garbage)

    was = gc.isenabled()
    gc.disable()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        plan = density_gradient_plan(model, RNG.normal(size=(2, n)), method="commuting",
                                     shots=10)
        during = views()  # found by the build's own collections
        gc.collect()
        left = views() - during
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        if was:
            gc.enable()
    del held, plan
    assert model.num_subunitaries == 17 and during >= 15 and during + left == 17
