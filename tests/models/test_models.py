"""DensityQNN and density gradients against independent oracles.

Oracles: density matrices built from ``Operator`` of the bound sub-unitaries (eq. 1),
central finite differences of the exact model.
"""


import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from qiskit.quantum_info import DensityMatrix, Operator, PauliList, SparsePauliOp, Statevector

from qdensity.circuits.ansatze import (
    angle_encoding,
    equivariant_commuting,
    hardware_efficient,
    pyramid,
    round_robin,
)
from qdensity.execution.exact import ExactEngine
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients import commuting_blocks
from qdensity.gradients.density import chain_rule, density_gradient_plan
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments, copies, odd_even, trainable_parameters
from qdensity.models.exact import z_readout_diagonal
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture

RNG = np.random.default_rng(11)


def _unary_state(x):
    n = len(x)
    vec = np.zeros(2**n)
    vec[1 << np.arange(n)] = x / np.linalg.norm(x)
    return Statevector(vec)


def _rho(model, x):
    """sum_k alpha_k U_k |x><x| U_k^dagger from dense operators (eq. 1)."""
    alpha = model.alpha(x[None, :])[0]
    psi = DensityMatrix(_unary_state(x))
    rho = np.zeros((2**model.num_qubits,) * 2, dtype=complex)
    for k, sub in enumerate(model.sub_unitaries):
        params = trainable_parameters(sub)
        bound = sub.assign_parameters(dict(zip(params, model._sub_theta(k, None), strict=True)))
        U = Operator(bound).data
        rho += alpha[k] * U @ psi.data @ U.conj().T
    return rho


@pytest.mark.parametrize("readout", ["observable", "unary_probabilities"])
@pytest.mark.parametrize("method", ["unary", "statevector"])
def test_predict_equals_density_matrix_oracle(readout, method):
    n = 4
    dec = by_moments(round_robin(n))
    obs = SparsePauliOp.from_list([("IIZZ", 0.6), ("ZIII", -0.4)])
    model = DensityQNN(dec.sub_unitaries, SoftmaxMixture(logits=RNG.normal(size=3)),
                       encoding=Encoding.unary(n), observable=obs, readout=readout, seed=3)
    X = RNG.normal(size=(3, n))
    got = model.predict(X, method=method)
    for b, x in enumerate(X):
        rho = _rho(model, x)
        if readout == "observable":
            want = np.real(np.trace(obs.to_matrix() @ rho))
            assert got[b] == pytest.approx(want, abs=1e-10)
        else:
            want = np.real(np.diag(rho))[1 << np.arange(n)]
            np.testing.assert_allclose(got[b], want, atol=1e-10)


def test_non_diagonal_observable_falls_back_to_statevector():
    n = 3
    obs = SparsePauliOp.from_list([("XXI", 1.0), ("IYY", 0.5)])
    model = DensityQNN([pyramid(n)], encoding=Encoding.unary(n), observable=obs, seed=1)
    x = RNG.normal(size=n)
    want = np.real(np.trace(obs.to_matrix() @ _rho(model, x)))
    assert model.predict(x[None, :])[0] == pytest.approx(want, abs=1e-10)
    with pytest.raises(ValueError, match="unary engine"):
        model.predict(x[None, :], method="unary")


def test_gated_mixture_is_data_dependent_and_matches_oracle():
    n = 4
    dec = by_moments(round_robin(n))
    gate = GatedMixture(n, 3, activation="gelu", seed=2)
    model = DensityQNN(dec.sub_unitaries, gate, encoding=Encoding.unary(n), seed=4)
    X = RNG.normal(size=(2, n))
    alphas = model.alpha(X)
    assert not np.allclose(alphas[0], alphas[1])
    for b, x in enumerate(X):
        want = np.real(np.trace(model.observable.to_matrix() @ _rho(model, x)))
        assert model.predict(X)[b] == pytest.approx(want, abs=1e-10)


def test_equivariant_density_model_on_angle_encoding():
    n = 4
    xx = equivariant_commuting(n, "X")
    yy = equivariant_commuting(n, "Y", parameter_prefix="φ")
    obs = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    model = DensityQNN([xx, yy], [0.7, 0.3], encoding=Encoding.angle(n), observable=obs, seed=5)
    x = RNG.uniform(-1, 1, size=n)
    enc = angle_encoding(n).assign_parameters(x)
    rho = np.zeros((2**n, 2**n), dtype=complex)
    psi = Statevector(enc).data
    for a, sub, k in ((0.7, xx, 0), (0.3, yy, 1)):
        U = Operator(sub.assign_parameters(model._sub_theta(k, None))).data
        v = U @ psi
        rho += a * np.outer(v, v.conj())
    want = np.real(np.trace(obs.to_matrix() @ rho))
    assert model.predict(x[None, :])[0] == pytest.approx(want, abs=1e-9)
    shifted = model.predict(np.roll(x, 1)[None, :])[0]
    assert shifted == pytest.approx(want, abs=1e-9)  # equivariance under cyclic shifts


@pytest.mark.parametrize("readout", ["observable", "unary_probabilities"])
@pytest.mark.parametrize("method", ["shift", "commuting"])
def test_density_gradient_matches_finite_differences(readout, method):
    n = 4
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, SoftmaxMixture(alpha=[0.2, 0.3, 0.5]),
                       encoding=Encoding.unary(n), readout=readout, seed=1)
    X = RNG.normal(size=(2, n))
    grad = density_gradient_plan(model, X, method=method).run(ExactEngine())
    m = n if readout != "observable" else 1
    up = RNG.normal(size=(2, m))
    g_theta, g_mix = chain_rule(model, X, grad, up)

    def loss(theta, mix):
        model.set_params(theta, mix)
        out = model.predict(X)
        return float((out.reshape(2, m) * up).sum())

    th, mx = model.theta.copy(), model.mixture.params
    h = 1e-6
    fd_t = [(loss(th + e, mx) - loss(th - e, mx)) / (2 * h) for e in np.eye(th.size) * h]
    fd_m = [(loss(th, mx + e) - loss(th, mx - e)) / (2 * h) for e in np.eye(mx.size) * h]
    model.set_params(th, mx)
    np.testing.assert_allclose(g_theta, fd_t, atol=1e-7)
    np.testing.assert_allclose(g_mix, fd_m, atol=1e-7)


def test_shared_parameters_prop1_sum_over_subunitaries():
    """Two sub-unitaries sharing every parameter: the gradient sums both (Prop. 1)."""
    n = 3
    u = pyramid(n)
    model = DensityQNN([u, u.reverse_ops()], [0.4, 0.6], encoding=Encoding.unary(n), seed=2)
    assert model.shares_parameters
    X = RNG.normal(size=(1, n))
    grad = density_gradient_plan(model, X, method="shift").run(ExactEngine())
    g, _ = chain_rule(model, X, grad, np.ones((1, 1)))
    th = model.theta.copy()
    fd = []
    for e in np.eye(th.size) * 1e-6:
        fd.append((model.predict(X, th + e)[0] - model.predict(X, th - e)[0]) / 2e-6)
    np.testing.assert_allclose(g, fd, atol=1e-7)


def test_commuting_block_subunitaries_cor2():
    """Sub-unitaries of B_k commuting blocks, Pauli readout: 2 sum_k B_k - K gradient circuits
    (Cor. 2), gradient against finite differences, fewer circuits than parameter shift."""
    n = 4
    subs = [pyramid(n), round_robin(n)]
    blocks = [len(commuting_blocks(s)) for s in subs]
    assert blocks == [2 * n - 3, n - 1]
    model = DensityQNN(subs, SoftmaxMixture(alpha=[0.4, 0.6]), encoding=Encoding.unary(n),
                       observable="ZIII", seed=3)
    X = RNG.normal(size=(2, n))
    plan = density_gradient_plan(model, X, method="auto")
    assert plan.meta["methods"] == ["commuting", "commuting"]
    assert plan.meta["gradient_circuits"] == 2 * sum(blocks) - len(subs)
    shift = density_gradient_plan(model, X, method="shift").meta["gradient_circuits"]
    assert shift == 4 * sum(s.num_parameters for s in subs)  # four-term rule per RBS
    grad = plan.run(ExactEngine())
    up = RNG.normal(size=(2, 1))
    g_theta, _ = chain_rule(model, X, grad, up)
    th = model.theta.copy()
    fd = []
    for e in np.eye(th.size) * 1e-6:
        hi = model.predict(X, th + e).reshape(2, 1)
        lo = model.predict(X, th - e).reshape(2, 1)
        fd.append(float(((hi - lo) * up).sum()) / 2e-6)
    np.testing.assert_allclose(g_theta, fd, atol=1e-7)
    # sum_i Z_i: 2 T (B - 1) + 1 circuits; pyramid 2*4*4 + 1 = 33 > 24 by shift, round-robin
    # 2*4*2 + 1 = 17 < 24: "auto" takes the fewer, "commuting" insists
    sum_z = DensityQNN(subs, encoding=Encoding.unary(n),
                       observable=SparsePauliOp(["ZIII", "IZII", "IIZI", "IIIZ"]))
    auto = density_gradient_plan(sum_z, X, method="auto")
    assert auto.meta["methods"] == ["shift", "commuting"]
    assert auto.meta["gradient_circuits"] == 24 + 17
    assert density_gradient_plan(sum_z, X, method="commuting").meta["gradient_circuits"] == 33 + 17
    sampled_plan = density_gradient_plan(model, X, method="commuting", shots=4000)
    engine = SamplerEngine(seed=5)
    sampled = sampled_plan.run(engine)
    assert engine.ledger.total_shots == sampled_plan.total_shots
    for je, js, se in zip(grad.jacobians, sampled.jacobians, sampled.jacobian_errors,
                          strict=True):
        informative = se > 1e-3
        assert informative.sum() >= 4
        assert np.all(np.abs(js - je)[informative] <= 5 * se[informative])


def test_sampled_density_gradient_within_standard_errors():
    n = 4
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(n),
                       readout="unary_probabilities", seed=6)
    X = RNG.normal(size=(2, n))
    exact = density_gradient_plan(model, X, method="commuting").run(ExactEngine())
    plan = density_gradient_plan(model, X, method="commuting", shots=4000)
    engine = SamplerEngine(seed=123)
    sampled = plan.run(engine)
    assert engine.ledger.total_shots == plan.total_shots
    for je, js, se in zip(exact.jacobians, sampled.jacobians, sampled.jacobian_errors,
                          strict=True):
        z = np.abs(js - je) / np.maximum(se, 1e-3)
        assert z.max() < 5.0


def test_decomposition_parameter_counts():
    assert by_moments(round_robin(6)).num_parameters == 15
    assert odd_even(pyramid(5)).num_parameters == 10
    assert copies(hardware_efficient(3, 2), 4).num_parameters == 24


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"sub_unitaries": []}, "list or tuple of 1 to"),
        ({"sub_unitaries": [round_robin(3), round_robin(4)]}, "same width"),
        ({"sub_unitaries": [round_robin(3)], "mixture": [0.5, 0.6]}, "sum to 1"),
        ({"sub_unitaries": [round_robin(3)] * 2, "mixture": [-0.5, 1.5]}, "non-negative"),
        ({"sub_unitaries": [round_robin(3)] * 2, "mixture": [np.nan, 0.5]}, "finite"),
        ({"sub_unitaries": [round_robin(3)], "readout": "amplitudes"}, "readout"),
        ({"sub_unitaries": [round_robin(3)], "observable": "ZZ"}, "2 qubits"),
        ({"sub_unitaries": [round_robin(3)], "readout": "unary_probabilities"}, "unary encoding"),
    ],
)
def test_bad_model_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DensityQNN(**kwargs)


def test_gated_mixture_wrong_shape():
    with pytest.raises(ValueError, match=r"\(3, 4\)"):
        GatedMixture(4, 3, weights=np.zeros((4, 3)))



@pytest.mark.parametrize("scheduler", ["per_shot", "proportional", "neyman"])
def test_train_mode_samples_subunitaries_unbiased(scheduler):
    n = 4
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, [0.5, 0.3, 0.2], encoding=Encoding.unary(n), seed=8)
    x = RNG.normal(size=n)
    exact = model.predict(x[None, :])[0]
    res = model.train().sample(x, 6000, scheduler=scheduler, seed=_stat_seed(4))
    assert res.shots_used <= 6000
    # a normal estimate leaves 4 standard errors with probability 2 Phi(-4) = 6e-5
    assert abs(res.estimate - exact) < 4 * res.standard_error + 1e-9


def test_a_named_target_is_one_device_for_the_whole_call():
    """A target name samples the device ``get_target(name, seed=seed)`` in every phase (the
    neyman pilot and main phase alike): the same shots as passing that device itself."""
    from qdensity.hardware.targets import get_target

    n = 3
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, [0.5, 0.3, 0.2],
                       encoding=Encoding.unary(n), seed=2)
    x = RNG.normal(size=n)
    by_name = model.train().sample(x, 400, scheduler="neyman", target="line", seed=5)
    device = get_target("line", n, seed=5)
    by_object = model.train().sample(x, 400, scheduler="neyman", target=device, seed=5)
    assert by_name.estimate == by_object.estimate
    np.testing.assert_array_equal(by_name.allocation, by_object.allocation)


def test_eval_mode_samples_the_deterministic_state():
    n = 3
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, [0.6, 0.3, 0.1], encoding=Encoding.unary(n), seed=9)
    x = RNG.normal(size=n)
    exact = np.real(np.trace(model.observable.to_matrix() @ _rho(model, x)))
    res = model.eval().sample(x, 8000, seed=_stat_seed(2))
    assert res.name == "deterministic" and res.shots_used == 8000
    assert abs(res.estimate - exact) < 4 * res.standard_error  # false failure: 6e-5


def test_sample_refuses_bad_input():
    model = DensityQNN([round_robin(3)], encoding=Encoding.unary(3),
                       observable=SparsePauliOp("XII"))
    with pytest.raises(ValueError, match="diagonal"):
        model.sample(np.ones(3), 100)
    model = DensityQNN([round_robin(3)], encoding=Encoding.unary(3))
    with pytest.raises(ValueError, match="scheduler"):
        model.sample(np.ones(3), 100, scheduler="magic")


@pytest.mark.parametrize("scheduler", ["proportional", "neyman"])
def test_sample_ledger_labels_pilot_apart_from_allocation(scheduler):
    from qdensity.execution.sampler.engine import SamplerEngine

    n = 4
    dec = by_moments(round_robin(n))
    model = DensityQNN(dec.sub_unitaries, [0.5, 0.3, 0.2], encoding=Encoding.unary(n), seed=8)
    engine = SamplerEngine(seed=5)
    res = model.train().sample(RNG.normal(size=n), 1000, scheduler=scheduler, engine=engine)
    spent = engine.ledger.by_label()
    main = [spent.get(f"randomised_k{k}", (0, 0))[1] for k in range(3)]
    pilot = [spent.get(f"pilot_k{k}", (0, 0))[1] for k in range(3)]
    assert main == res.allocation.tolist()
    expected_pilot = [0, 0, 0] if scheduler != "neyman" else res.pilot_allocation.tolist()
    assert pilot == expected_pilot
    assert sum(main) + sum(pilot) == res.shots_used == engine.ledger.total_shots == 1000



def test_unary_readout_diagonal_against_the_dense_observable():
    # <e_j|O|e_j> read from the Pauli terms equals the dense matrix's diagonal at 2**j,
    # a Pauli phase (-1) included
    n = 5
    obs = SparsePauliOp(PauliList(["ZIZII", "IIIIZ", "-IZZZI", "IIIII"]), [0.7, -1.3, 2.0, 0.4])
    model = DensityQNN([pyramid(n)], encoding=Encoding.unary(n), observable=obs, seed=0)
    dense = np.real(np.diag(obs.to_matrix()))
    np.testing.assert_allclose(z_readout_diagonal(model.observable), dense[1 << np.arange(n)],
                               atol=1e-12)


def test_unary_prediction_at_width_40_needs_no_2n_table():
    # all RBS angles 0: U = 1, so y = x / |x| and Z_0 reads sum_j y_j^2 (1 - 2 [j = 0])
    n = 40
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN([pyramid(n)], encoding=Encoding.unary(n), observable=obs, seed=0)
    X = np.random.default_rng(1).normal(size=(3, n))
    expect = 1 - 2 * X[:, 0] ** 2 / np.sum(X**2, axis=1)
    got = model.predict(X, np.zeros(model.num_parameters), method="unary")
    np.testing.assert_allclose(got, expect, atol=1e-12)
