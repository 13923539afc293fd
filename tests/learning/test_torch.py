"""The PyTorch module: gradcheck in double precision on the exact paths, gradients against
finite differences of Aer statevectors, sampled gradients against exact ones, the input
gradient that lets a classical layer before it train, a gate written in torch, bad input, and
the runnable examples."""

import pickle
import runpy
from pathlib import Path

import numpy as np
import pytest
from _stats import stat_seed as _stat_seed
from _stats import unary_input_vjp_sd

torch = pytest.importorskip("torch")  # the optional extra; CI installs it (.ci/run)

from qiskit import QuantumCircuit  # noqa: E402
from torch import nn  # noqa: E402
from torch.autograd import gradcheck  # noqa: E402

from qdensity.circuits.ansatze import hardware_efficient, round_robin  # noqa: E402
from qdensity.execution.sampler.engine import SamplerEngine  # noqa: E402
from qdensity.learning.torch import DensityQNNLayer, MoEGate  # noqa: E402
from qdensity.models import DensityQNN, Encoding  # noqa: E402
from qdensity.models.decompositions import by_moments, copies  # noqa: E402
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _unary_model(mixture="softmax", readout="unary_probabilities", n=4, seed=0):
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    mix = {"softmax": SoftmaxMixture(K), "fixed": None,
           "moe": GatedMixture(n, K, activation="gelu", seed=seed + 1)}[mixture]
    return DensityQNN(dec.sub_unitaries, mix, encoding=Encoding.unary(n), readout=readout,
                      seed=seed)


def _functional(layer):
    names = [n for n, _ in layer.named_parameters()]
    params = tuple(p.detach().clone().requires_grad_() for p in layer.parameters())

    def f(x, *ps):
        return torch.func.functional_call(layer, dict(zip(names, ps, strict=True)), (x,))

    return f, params


@pytest.mark.parametrize(("mixture", "readout"), [
    ("softmax", "unary_probabilities"), ("moe", "unary_probabilities"),
    ("fixed", "unary_amplitudes"), ("softmax", "observable"),
])
def test_gradcheck_exact_unary_path_including_the_input(mixture, readout):
    layer = DensityQNNLayer(_unary_model(mixture, readout))
    x = (torch.rand(3, 4, dtype=torch.float64) + 0.1).requires_grad_()
    f, params = _functional(layer)
    assert gradcheck(f, (x, *params))


@pytest.mark.parametrize("mixture", ["fixed", "softmax"])
def test_one_sub_unitary_skips_the_mixture_and_keeps_exact_gradients(mixture):
    """K = 1 (the pure model): the output is f_1 itself (no mixing ops), equal to Aer
    statevector predictions; gradcheck through the angles and the input."""
    mix = SoftmaxMixture(1) if mixture == "softmax" else None
    model = DensityQNN([round_robin(4)], mix, encoding=Encoding.unary(4),
                       readout="unary_probabilities", seed=6)
    layer = DensityQNNLayer(model)
    assert layer._single
    X = np.random.default_rng(7).normal(size=(5, 4))
    with torch.no_grad():
        np.testing.assert_allclose(layer(torch.tensor(X)).numpy(),
                                   model.predict(X, method="statevector"), atol=1e-12)
    x = (torch.rand(3, 4, dtype=torch.float64) + 0.1).requires_grad_()
    f, params = _functional(layer)
    assert gradcheck(f, (x, *params))


def _angle_hea_model():
    circ = hardware_efficient(3, 2, ("ry", "rz"))
    return DensityQNN(copies(circ, 2).sub_unitaries, SoftmaxMixture(2),
                      encoding=Encoding.angle(3), seed=2)


def _reuploading_model():
    # two sub-unitaries that re-upload x[0] (and x[1] in the second) between trained layers
    from qiskit.circuit import ParameterVector

    subs = []
    for k in range(2):
        x, t = ParameterVector("x", 2), ParameterVector(f"t{k}", 6)
        qc = QuantumCircuit(2)
        for layer in range(2):
            qc.rx(x[0], 0)
            qc.rx(x[1] if k else 0.7 * x[0], 1)
            qc.ry(t[3 * layer], 0)
            qc.rz(t[3 * layer + 1], 1)
            qc.cz(0, 1)
            qc.ry(t[3 * layer + 2], 1)
        subs.append(qc)
    return DensityQNN(subs, SoftmaxMixture(2), seed=3)


def _qcnn_model():
    from qdensity.circuits.ansatze import qcnn

    return DensityQNN([qcnn(4)], SoftmaxMixture(1), encoding=Encoding.angle(4), seed=4)


def _angle_hea_moe_model():
    # a data-dependent mixture on the adjoint path: the gate copied into torch
    circ = hardware_efficient(3, 1)
    return DensityQNN(copies(circ, 2).sub_unitaries, GatedMixture(3, 2, seed=9),
                      encoding=Encoding.angle(3), seed=9)


def _unary_hea_model():
    # a non-RBS circuit on the unary encoding: the input gradient goes through the loader
    return DensityQNN(copies(hardware_efficient(3, 1), 2).sub_unitaries, SoftmaxMixture(2),
                      encoding=Encoding.unary(3), seed=5)


@pytest.mark.parametrize("build", [_angle_hea_model, _reuploading_model, _qcnn_model,
                                   _unary_hea_model, _angle_hea_moe_model])
def test_gradcheck_inputs_and_weights_on_the_adjoint_path(build):
    """Every non-unary family: torch.autograd.gradcheck (central finite differences of the
    layer's own exact outputs) on the input and every weight at once."""
    layer = DensityQNNLayer(build())
    assert not layer._unary
    x = (torch.rand(2, layer.num_features, dtype=torch.float64) + 0.2).requires_grad_()
    f, params = _functional(layer)
    assert gradcheck(f, (x, *params))


def test_input_gradients_match_finite_differences_of_aer_statevectors():
    """d/dx of sum(w * f(x)) on the angle-encoded model against central differences of
    DensityQNN.predict on Aer statevectors (an independent simulator)."""
    model = _angle_hea_model()
    layer = DensityQNNLayer(model)
    X = np.random.default_rng(5).normal(size=(2, 3))
    w = np.random.default_rng(6).normal(size=(2, 1))
    x = torch.tensor(X, requires_grad=True)
    (layer(x) * torch.tensor(w)).sum().backward()
    h = 1e-5
    fd = np.zeros_like(X)
    for b in range(2):
        for i in range(3):
            e = np.zeros_like(X)
            e[b, i] = h
            plus = model.predict(X + e, method="statevector").reshape(2, -1)
            minus = model.predict(X - e, method="statevector").reshape(2, -1)
            fd[b, i] = ((plus - minus) * w).sum() / (2 * h)
    np.testing.assert_allclose(x.grad.numpy(), fd, atol=1e-7)


def test_inputs_of_any_leading_shape():
    layer = DensityQNNLayer(_angle_hea_model())
    X = torch.tensor(np.random.default_rng(8).normal(size=(2, 3, 3)))
    with torch.no_grad():
        flat = layer(X.reshape(6, 3))
        assert layer(X).shape == (2, 3, 1)
        torch.testing.assert_close(layer(X).reshape(6, 1), flat)
        assert layer(X[0, 0]).shape == (1,)
        torch.testing.assert_close(layer(X[0, 0]), flat[0])
    x = X.clone().requires_grad_()
    layer(x).sum().backward()
    assert x.grad.shape == X.shape
    with pytest.raises(ValueError, match=r"\(\.\.\., d\)"):
        layer(torch.zeros(2, 4, dtype=torch.float64))



def test_sampled_input_gradients_within_standard_errors_and_counted():
    """A SamplerEngine: d/dx by shift rules on the data parameters, within 4 standard errors
    of the exact input gradient, its circuits and shots on the ledger."""
    from qdensity.gradients.inputs import input_gradient_plan

    model = _angle_hea_model()
    X = np.random.default_rng(4).normal(size=(2, 3))
    exact = DensityQNNLayer(model)
    x = torch.tensor(X, requires_grad=True)
    exact(x).sum().backward()
    engine = SamplerEngine(seed=_stat_seed(5))
    shots = 4000
    layer = DensityQNNLayer(model, engine=engine, shots=shots)
    xs = torch.tensor(X, requires_grad=True)
    layer(xs).sum().backward()
    assert layer.shots_spent == engine.ledger.total_shots
    meta = input_gradient_plan(model, X).meta["input_circuits"]
    assert layer.circuits >= 2 * meta and layer.shots_spent >= 2 * meta * shots
    # x_i enters one R_y(pi x_i / 2) per sub-unitary; its shift estimate of <Z_0> is
    # (pi / 2) (f+ - f-) / 2, variance <= (pi / 2)^2 (1 + 1) / 4 / shots; the output weighs
    # K = 2 of them by alpha = 1/2: variance <= pi^2 / 16 / shots
    # 2 x 3 entries, each normal with sd <= se: false failure <= 6 x 2 Phi(-4) = 4e-4
    se = np.pi / 4 / np.sqrt(shots)
    assert float((xs.grad - x.grad).abs().max()) < 4 * se


def test_sampled_unary_input_gradient_through_the_loader_and_a_torch_gate():
    """Unary probabilities on a SamplerEngine with the model's MoE gate copied into torch:
    d/dx from the four-term rule on the loader's RBS angles chained with d phi / dx (plus the
    gate's d alpha / dx by autograd, times the sampled outputs) within a derived bound of the
    exact layer's; the input-gradient shots on the ledger as the plan's meta states."""
    from qdensity.gradients.inputs import input_gradient_plan, loader_angles_jacobian

    model = _unary_model("moe", seed=8)
    X = np.random.default_rng(9).uniform(0.2, 1.0, (2, 4))
    w = np.random.default_rng(10).normal(size=(2, 4))
    exact = DensityQNNLayer(model)
    x = torch.tensor(X, requires_grad=True)
    (exact(x) * torch.tensor(w)).sum().backward()
    shots = 10_000
    engine = SamplerEngine(seed=_stat_seed(12))
    layer = DensityQNNLayer(model, engine=engine, shots=shots)
    xs = torch.tensor(X, requires_grad=True)
    (layer(xs) * torch.tensor(w)).sum().backward()
    assert layer.shots_spent == engine.ledger.total_shots
    meta = input_gradient_plan(model, X).meta
    spent = sum(s for label, (_, s) in engine.ledger.by_label().items()
                if label.startswith("input_gradient"))
    assert spent == 2 * meta["input_circuits"] * shots
    xg = torch.tensor(X, requires_grad=True)  # d alpha_k / dx of the torch gate, for the bound
    gate_jac = torch.autograd.functional.jacobian(layer.gate, xg).numpy()  # (B, K, B, d)
    gate_jac = np.stack([gate_jac[b, :, b, :] for b in range(2)])
    with torch.no_grad():
        alpha = layer.gate(torch.tensor(X)).numpy()
    sd = unary_input_vjp_sd(alpha, loader_angles_jacobian(X), w, shots, gate_jac)
    # B x d = 8 entries, each normal with sd below the bound, within 5 of it:
    # false failure <= 8 x 2 Phi(-5) = 4.6e-6
    assert np.all(np.abs(xs.grad.numpy() - x.grad.numpy()) <= 5 * sd)


def test_gradients_match_finite_differences_of_aer_statevectors():
    """d/dtheta of sum(w * f(x)) against central differences of DensityQNN.predict computed
    with Aer statevectors (method="statevector"), an independent path."""
    model = _unary_model("softmax", n=3, seed=3)
    layer = DensityQNNLayer(model)
    X = np.random.default_rng(0).normal(size=(2, 3))
    w = np.random.default_rng(1).normal(size=(2, 3))
    (layer(torch.tensor(X)) * torch.tensor(w)).sum().backward()
    h = 1e-5
    fd = []
    for p in range(model.num_parameters):
        e = np.zeros(model.num_parameters)
        e[p] = h
        plus = model.predict(X, model.theta + e, method="statevector")
        minus = model.predict(X, model.theta - e, method="statevector")
        fd.append(((plus - minus) * w).sum() / (2 * h))
    np.testing.assert_allclose(layer.theta.grad.numpy(), fd, atol=1e-7)


def test_sampled_gradients_agree_with_exact_within_standard_errors():
    model = _unary_model("softmax", seed=4)
    X = torch.tensor(np.random.default_rng(2).normal(size=(4, 4)))
    w = torch.tensor(np.random.default_rng(3).normal(size=(4, 4)))
    exact = DensityQNNLayer(model)
    (exact(X) * w).sum().backward()
    shots = 4000
    engine = SamplerEngine(seed=_stat_seed(11))
    sampled = DensityQNNLayer(model, engine=engine, shots=shots, gradient="commuting")
    (sampled(X) * w).sum().backward()
    assert sampled.shots_spent == engine.ledger.total_shots > 0
    # every gradient entry is a sum over 4 rows x 4 outputs of |w| * (estimates of
    # probabilities or their differences, each with variance <= 1 / shots); bound the error
    se = np.sqrt((w.numpy() ** 2).sum() * 2.0 / shots)
    # each entry normal with sd <= se; over the theta and logit entries (model.num_parameters
    # + K <= 16): false failure <= 16 x 2 Phi(-4) = 1e-3
    assert model.num_parameters + model.num_subunitaries <= 16
    for name in ("theta", "logits"):
        diff = getattr(sampled, name).grad - getattr(exact, name).grad
        assert float(diff.abs().max()) < 4 * se, name
    with torch.no_grad():  # evaluation is exact and spends nothing
        spent = engine.ledger.total_shots
        torch.testing.assert_close(sampled(X), exact(X))
        assert engine.ledger.total_shots == spent


def test_classical_layer_before_the_quantum_layer_trains():
    torch.manual_seed(0)
    pre = nn.Linear(6, 4, dtype=torch.float64)
    net = nn.Sequential(pre, nn.Softplus(), DensityQNNLayer(_unary_model()),
                        nn.Linear(4, 2, dtype=torch.float64))
    X = torch.randn(32, 6, dtype=torch.float64)
    y = (X[:, 0] > 0).long()
    opt = torch.optim.Adam(net.parameters(), lr=0.05)
    losses = []
    for _ in range(40):
        opt.zero_grad()
        loss = nn.functional.cross_entropy(net(X), y)
        loss.backward()
        assert float(pre.weight.grad.abs().sum()) > 0
        opt.step()
        losses.append(loss.item())
    assert np.mean(losses[-5:]) < 0.8 * np.mean(losses[:5])


def test_gate_written_in_torch_and_copy_of_the_model_gate():
    model = _unary_model("moe", seed=5)
    layer = DensityQNNLayer(model)
    assert isinstance(layer.gate, MoEGate)
    X = np.abs(np.random.default_rng(4).normal(size=(5, 4))) + 0.1
    with torch.no_grad():  # the copied gate reproduces the numpy model exactly
        np.testing.assert_allclose(layer(torch.tensor(X)).numpy(), model.predict(X), atol=1e-12)
    back = layer.to_model()
    np.testing.assert_allclose(back.predict(X), model.predict(X), atol=1e-12)
    custom = nn.Sequential(nn.Linear(4, 3, dtype=torch.float64), nn.Softmax(dim=-1))
    mine = DensityQNNLayer(_unary_model("fixed"), gate=custom)
    x = torch.tensor(X, requires_grad=True)
    f, params = _functional(mine)
    assert gradcheck(f, (x, *params))
    with pytest.raises(ValueError, match="custom torch gate"):
        mine.to_model()


def test_module_pickles():
    layer = DensityQNNLayer(_unary_model("moe"))
    x = torch.rand(2, 4, dtype=torch.float64)
    back = pickle.loads(pickle.dumps(layer))
    torch.testing.assert_close(back(x), layer(x))


def test_bad_input():
    layer = DensityQNNLayer(_unary_model())
    with pytest.raises(TypeError, match="input must be a floating-point tensor"):
        layer(torch.ones(2, 4, dtype=torch.int64))
    with pytest.raises(ValueError, match=r"input must have shape .* d = 4 .* got \(2, 5\)"):
        layer(torch.ones(2, 5, dtype=torch.float64))
    with pytest.raises(ValueError, match=r"input must have shape"):
        layer(torch.ones((), dtype=torch.float64))
    with pytest.raises(ValueError, match=r"input must have shape"):
        layer(torch.ones(0, 4, dtype=torch.float64))
    with pytest.raises(TypeError, match="input must be a torch.Tensor"):
        layer(np.ones((2, 4)))
    with pytest.raises(ValueError, match="all-zero"):
        layer(torch.zeros(1, 4, dtype=torch.float64))
    with pytest.raises(TypeError, match="model must be a DensityQNN"):
        DensityQNNLayer("round_robin")
    with pytest.raises(ValueError, match="shots"):
        DensityQNNLayer(_unary_model(), engine=SamplerEngine(seed=0))
    with pytest.raises(ValueError, match="gradient must be one of"):
        DensityQNNLayer(_unary_model(), gradient="adjoint-ish")
    with pytest.raises(ValueError, match="engine must be"):
        DensityQNNLayer(_unary_model(), engine="gpu")
    frozen = DensityQNN([QuantumCircuit(3)], encoding=Encoding.unary(3),
                        readout="unary_probabilities")
    with pytest.raises(ValueError, match="no trainable parameters"):
        DensityQNNLayer(frozen)


def test_examples_run():
    first, last, acc = runpy.run_path(str(EXAMPLES / "hybrid_mnist.py"))["main"](
        epochs=2, samples=120, verbose=False)
    assert last < first and 0 <= acc <= 1
    first, last, acc, grad_norm = runpy.run_path(str(EXAMPLES / "moe_gate_torch.py"))["main"](
        steps=20, verbose=False)
    assert last < first and grad_norm > 0
