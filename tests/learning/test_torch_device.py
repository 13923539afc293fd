"""DensityQNNLayer on the torch engines (CPU torch): values against qiskit statevectors and the
numpy engines, gradcheck (central finite differences) on input and weights, dtypes, the
device of the inputs (``meta``: a device without data, so nothing can cross to numpy), bad
input."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the optional extra; CI installs it (.ci/run)

from qiskit import QuantumCircuit  # noqa: E402
from qiskit.circuit import ParameterVector  # noqa: E402
from torch.autograd import gradcheck  # noqa: E402

from qdensity.circuits.ansatze import hardware_efficient, qcnn, round_robin  # noqa: E402
from qdensity.learning.torch import DensityQNNLayer  # noqa: E402
from qdensity.models import DensityQNN, Encoding  # noqa: E402
from qdensity.models.decompositions import by_moments, copies  # noqa: E402
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture  # noqa: E402


def _unary_model(mixture="softmax", readout="unary_probabilities", n=4, seed=0):
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    mix = {"softmax": SoftmaxMixture(K), "fixed": None,
           "moe": GatedMixture(n, K, activation="gelu", seed=seed + 1)}[mixture]
    return DensityQNN(dec.sub_unitaries, mix, encoding=Encoding.unary(n), readout=readout,
                      seed=seed)


def _angle_model():
    return DensityQNN(copies(hardware_efficient(3, 2, ("ry", "rz")), 2).sub_unitaries,
                      SoftmaxMixture(2), encoding=Encoding.angle(3), seed=2)


def _reuploading_model():
    subs = []
    for k in range(2):
        x, t = ParameterVector("x", 2), ParameterVector(f"t{k}", 4)
        qc = QuantumCircuit(2)
        for layer in range(2):
            qc.rx(x[0], 0)
            qc.rx(x[1] if k else 0.7 * x[0], 1)
            qc.ry(t[2 * layer], 0)
            qc.cz(0, 1)
            qc.ry(t[2 * layer + 1], 1)
        subs.append(qc)
    return DensityQNN(subs, SoftmaxMixture(2), seed=3)


def _qcnn_model():
    return DensityQNN([qcnn(4)], SoftmaxMixture(1), encoding=Encoding.angle(4), seed=4)


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
def test_unary_models_on_the_torch_engine(mixture, readout):
    model = _unary_model(mixture, readout)
    layer = DensityQNNLayer(model, engine="torch")
    X = np.random.default_rng(1).uniform(0.1, 1.0, size=(5, 4))
    with torch.no_grad():  # oracle: Aer's statevector predictions of the model (amplitudes,
        out = layer(torch.tensor(X)).numpy()  # whose signs Aer's probabilities lack: numpy's)
    method = "unary" if readout == "unary_amplitudes" else "aer"
    expected = model.predict(X, method=method)
    np.testing.assert_allclose(out, expected.reshape(out.shape), atol=1e-10)
    x = (torch.rand(3, 4, dtype=torch.float64) + 0.1).requires_grad_()
    f, params = _functional(layer)
    assert gradcheck(f, (x, *params))


@pytest.mark.parametrize("build", [_angle_model, _reuploading_model, _qcnn_model])
def test_adjoint_models_on_the_torch_engine(build):
    model = build()
    layer, ref = DensityQNNLayer(model, engine="torch"), DensityQNNLayer(model)
    assert not layer._unary
    x = (torch.rand(3, layer.num_features, dtype=torch.float64) + 0.2).requires_grad_()
    y, y0 = layer(x), ref(x)
    np.testing.assert_allclose(y.detach().numpy(), y0.detach().numpy(), atol=1e-10)
    g = torch.autograd.grad(y.sum(), [x, layer.theta])
    g0 = torch.autograd.grad(y0.sum(), [x, ref.theta])
    for a, b in zip(g, g0, strict=True):
        np.testing.assert_allclose(a.numpy(), b.numpy(), atol=1e-10)
    f, params = _functional(layer)
    assert gradcheck(f, (x, *params))


def test_float32_inputs_give_float32_outputs_and_float64_weight_gradients():
    layer = DensityQNNLayer(_unary_model(), engine="torch")
    x = torch.rand(4, 4, dtype=torch.float32) + 0.1
    y = layer(x)
    assert y.dtype == torch.float32
    y.sum().backward()
    assert layer.theta.grad.dtype == torch.float64
    with torch.no_grad():
        y64 = DensityQNNLayer(_unary_model())(x.double())
    np.testing.assert_allclose(y.detach().numpy(), y64.numpy(), atol=1e-5)


@pytest.mark.parametrize("mixture", ["softmax", "moe"])
def test_the_layer_computes_on_the_device_of_its_inputs(mixture):
    """``layer.to(device)`` moves the weights; with ``engine="exact"`` an input on a non-CPU
    device runs the unary engine there (``meta`` has no data: any copy to numpy would fail)."""
    layer = DensityQNNLayer(_unary_model(mixture)).to("meta")
    assert layer.theta.device.type == "meta"
    x = torch.empty(6, 4, dtype=torch.float64, device="meta", requires_grad=True)
    y = layer(x)
    assert y.device.type == "meta" and y.shape == (6, 4)
    (gx,) = torch.autograd.grad(y.sum(), [x])
    assert gx.device.type == "meta" and gx.shape == (6, 4)


def test_bad_engine_names_the_choices():
    with pytest.raises(ValueError, match="'exact', 'torch' or a SamplerEngine"):
        DensityQNNLayer(_unary_model(), engine="cuda")


def test_quantum_layer_takes_the_torch_adjoint_engine():
    """The scikit-learn side's QuantumLayer with ``AdjointEngine(backend="torch")``: numpy in,
    numpy out, the numpy engine's outputs and input gradients."""
    from qdensity.execution.statevector.adjoint import AdjointEngine
    from qdensity.learning.layer import QuantumLayer

    Z = np.random.default_rng(3).uniform(0.1, 1.0, size=(4, 3))
    G = np.random.default_rng(4).normal(size=(4, 1))
    results = []
    for engine in (AdjointEngine(backend="torch"), AdjointEngine(backend="numpy")):
        layer = QuantumLayer(_angle_model(), engine=engine)
        out = layer.forward(Z)
        results.append((out, layer.backward(G), layer.grads["theta"]))
    for a, b in zip(*results, strict=True):
        assert isinstance(a, np.ndarray)
        np.testing.assert_allclose(a, b, atol=1e-10)
