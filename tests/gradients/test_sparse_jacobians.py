"""``density_gradient_plan(..., jacobian="sparse")``: the same Jacobians and errors as the
dense layout, entry for entry (the dense path is the oracle; it is checked against finite
differences of exact probabilities in ``test_plan_scaling.py`` and here once more through the
sparse layout), on exact and sampled, noiseless, readout-noisy and post-selected results."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp, Statevector
from qiskit.transpiler import Target
from qiskit_aer.noise import NoiseModel, ReadoutError
from scipy import sparse

from qdensity import DensityQNN, Encoding, ExactEngine, SamplerEngine, by_moments, get_target
from qdensity.circuits.ansatze import round_robin
from qdensity.gradients import chain_rule, density_gradient_plan

N = 6
RNG = np.random.default_rng(11)


def _model(n=N, readout="unary_probabilities"):
    subs = by_moments(round_robin(n)).sub_unitaries
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n) if readout == "observable" else None
    return DensityQNN(subs, encoding=Encoding.unary(n), readout=readout, observable=obs, seed=3)


def _readout_target(n, p=0.05):
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - p, p], [p, 1 - p]]))
    device = Target.from_configuration(["cz", "rz", "sx", "x", "measure"], num_qubits=n)
    return get_target(device, seed=0, noise_model=noise)


def _engines():
    return {
        "exact": lambda: ExactEngine(),
        "sampled": lambda: SamplerEngine(seed=5, progress=False),
        "readout-noisy": lambda: SamplerEngine(target=_readout_target(N), seed=5,
                                               progress=False),
        "postselected": lambda: SamplerEngine(seed=5, progress=False,
                                              postselect="hamming_weight"),
    }


def _both(model, X, engine_name, method="commuting"):
    shots = None if engine_name == "exact" else 400
    out = {}
    for layout in ("dense", "sparse"):
        plan = density_gradient_plan(model, X, method=method, shots=shots, jacobian=layout)
        out[layout] = plan.run(_engines()[engine_name]())  # same seed: the same shots
    return out["dense"], out["sparse"]


def _assert_same(dense, sparse_grad):
    np.testing.assert_array_equal(sparse_grad.outputs, dense.outputs)
    np.testing.assert_array_equal(sparse_grad.output_errors, dense.output_errors)
    for d, s in zip(dense.jacobians + dense.jacobian_errors,
                    sparse_grad.jacobians + sparse_grad.jacobian_errors, strict=True):
        assert isinstance(s, sparse.csr_array)
        B, m, P = d.shape
        assert s.shape == (B * m, P)
        np.testing.assert_array_equal(s.toarray(), d.reshape(B * m, P))


@pytest.mark.parametrize("engine_name", ["exact", "sampled", "readout-noisy", "postselected"])
def test_sparse_jacobians_equal_the_dense_ones(engine_name):
    model = _model()
    X = RNG.normal(size=(3, N))
    dense, sp = _both(model, X, engine_name)
    _assert_same(dense, sp)
    # a round-robin moment: each unary output depends on (at most) one parameter
    for jac, err in zip(sp.jacobians, sp.jacobian_errors, strict=True):
        assert jac.nnz <= jac.shape[0]
        assert np.array_equal(jac.indices, err.indices)
        assert np.array_equal(jac.indptr, err.indptr)


@pytest.mark.parametrize("method,readout", [("shift", "unary_probabilities"),
                                            ("commuting", "observable")])
def test_sparse_layout_of_shift_and_observable_plans(method, readout):
    """Parameter-shift plans (dense per sub-unitary, converted) and an observable readout
    (m = 1) give the same entries in the sparse layout."""
    model = _model(readout=readout)
    X = RNG.normal(size=(2, N))
    dense, sp = _both(model, X, "sampled", method)
    _assert_same(dense, sp)


def test_sparse_exact_jacobians_match_finite_differences():
    """The sparse layout read back (row ``b * m + j``) against central differences (step
    1e-5: error ~1e-10 plus rounding) of exact statevector probabilities."""
    n, eps = 5, 1e-5
    model = _model(n)
    X = RNG.normal(size=(2, n))
    grad = density_gradient_plan(model, X, method="commuting", jacobian="sparse").run(
        ExactEngine())
    for k in range(model.num_subunitaries):
        circ, rows = model.circuit(k), model.rows(k, X)
        own = set(model.sub_unitaries[k].parameters)
        cols = [i for i, p in enumerate(circ.parameters) if p in own]
        jac = grad.jacobians[k].toarray()
        for b in range(rows.shape[0]):
            for c, col in enumerate(cols):
                up, down = rows[b].copy(), rows[b].copy()
                up[col] += eps
                down[col] -= eps
                probs = [Statevector(circ.assign_parameters(r)).probabilities()[1 << np.arange(n)]
                         for r in (up, down)]
                np.testing.assert_allclose(jac[b * n:(b + 1) * n, c],
                                           (probs[0] - probs[1]) / (2 * eps), atol=1e-8)


def test_chain_rule_takes_sparse_jacobians():
    """The parameter and mixture gradients from sparse Jacobians equal the dense ones (sums in
    another order: rounding only)."""
    model = _model()
    X = RNG.normal(size=(3, N))
    dense, sp = _both(model, X, "sampled")
    upstream = RNG.normal(size=(3, N))
    g_dense, mix_dense = chain_rule(model, X, dense, upstream)
    g_sparse, mix_sparse = chain_rule(model, X, sp, upstream)
    np.testing.assert_allclose(g_sparse, g_dense, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(mix_sparse, mix_dense)


def test_jacobian_layout_is_checked_before_any_work():
    model = _model()
    with pytest.raises(ValueError, match="jacobian"):
        density_gradient_plan(model, np.zeros((1, N)), jacobian="csr")
    with pytest.raises((TypeError, ValueError), match="jacobian"):
        density_gradient_plan(model, np.zeros((1, N)), jacobian=1)


def test_sparse_sums_the_circuits_of_several_commuting_blocks():
    """A pyramid sub-unitary has several commuting blocks (2B - 1 circuits, Cor. 2): the
    sparse layout adds the circuits' estimates and variances as the dense one does."""
    from qdensity.circuits.ansatze import pyramid

    n = 4
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN([pyramid(n), pyramid(n)], encoding=Encoding.unary(n), observable=obs,
                       seed=2)
    X = RNG.normal(size=(2, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=300)
    assert plan.meta["gradient_circuits"] > 2  # several circuits per sub-unitary
    dense, sp = _both(model, X, "sampled")
    _assert_same(dense, sp)


def test_the_sum_table_of_unary_outputs_is_every_output_table_in_order():
    """The shared circuit's table (the sum of the outputs) holds every output's strings and
    coefficients in output order; the block keeps them once, by their nonzeros."""
    from qdensity.gradients.density import _circuit_of, _commuting_analysis

    model = _model()
    circ, params = _circuit_of(model, 1)
    shared, grads = _commuting_analysis(model, circ, params, 1)
    (total,) = shared._values
    np.testing.assert_array_equal(total.z, np.concatenate([g._values[0].z for g in grads]))
    np.testing.assert_array_equal(total.coefficients,
                                  np.concatenate([g._values[0].coefficients for g in grads]))
    stack = grads.tables  # one compact stack: each nonzero coefficient held once
    assert stack.entry_value.size == np.count_nonzero(total.coefficients)
    assert stack.support.shape == (total.z.shape[0], 2)
    assert len(grads) == model.num_qubits


def test_auto_layout_is_dense_when_small_and_sparse_when_large(monkeypatch):
    """No ``jacobian`` argument: dense ``(B, m, P_k)`` arrays while ``16 B m sum_k P_k`` bytes
    fit under the limit, the sparse layout (the same entries) above it. The limit is lowered
    here so that a 6-qubit model crosses it: 3 rows x 6 outputs x 15 parameters x 16 bytes =
    4,320 bytes."""
    from qdensity.gradients import _sparse

    model = _model()
    X = RNG.normal(size=(3, N))
    dense = density_gradient_plan(model, X, method="commuting", jacobian="dense").run(
        ExactEngine())
    small = density_gradient_plan(model, X, method="commuting")
    assert small.meta["jacobian"] == "dense"
    got = small.run(ExactEngine())
    for d, a in zip(dense.jacobians, got.jacobians, strict=True):
        assert isinstance(a, np.ndarray)
        np.testing.assert_array_equal(a, d)
    monkeypatch.setattr(_sparse, "DENSE_LIMIT_BYTES", 3 * N * 15 * 16 - 1)
    large = density_gradient_plan(model, X, method="commuting")
    assert large.meta["jacobian"] == "sparse"
    _assert_same(dense, large.run(ExactEngine()))
    monkeypatch.setattr(_sparse, "DENSE_LIMIT_BYTES", 3 * N * 15 * 16)
    assert density_gradient_plan(model, X, method="commuting").meta["jacobian"] == "dense"


@pytest.mark.parametrize("n,expected", [(64, "dense"), (256, "sparse"), (1024, "sparse")])
def test_auto_layout_of_the_round_robin_model_by_width(n, expected):
    """The round-robin model by moments, 16 rows: ``n - 1`` moments of ``n / 2`` parameters,
    ``n`` unary outputs; dense Jacobians and errors hold ``16 * 16 * n * n (n - 1) / 2`` bytes
    (33 MB at n = 64; 2.1 GB at n = 256)."""
    from qdensity.gradients._sparse import choose_layout

    assert choose_layout("auto", 16, n, n * (n - 1) // 2) == expected
    assert choose_layout("dense", 16, n, n * (n - 1) // 2) == "dense"
    assert choose_layout("sparse", 1, 1, 1) == "sparse"
