"""Second derivatives through the PyTorch layer and the unary engine's torch path: right or
refused, never zeros. On the torch engine (RBS/FBS models with a unary encoding) Hessians with
respect to the angles, the mixture logits and the input equal central finite differences of
the first-order gradient of the numpy engine (an independent code path); on every path whose
backward runs in numpy (exact engine, adjoint engine, sampled) a second derivative raises a
RuntimeError that names the torch engine, while ``create_graph=True`` alone still gives the
right first derivative. ``torch.compile`` gives the eager values and gradients."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the optional extra; CI installs it (.ci/run)

from torch.autograd.functional import hessian  # noqa: E402

from qdensity.circuits.ansatze import hardware_efficient, pyramid, round_robin  # noqa: E402
from qdensity.execution import unary  # noqa: E402
from qdensity.learning.torch import DensityQNNLayer  # noqa: E402
from qdensity.models import DensityQNN, Encoding  # noqa: E402
from qdensity.models.decompositions import by_moments, copies  # noqa: E402
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture  # noqa: E402

#: Central differences of an exact gradient with this step: truncation ~h^2 |f'''| ~ 1e-10,
#: rounding ~1e-16 / h ~ 1e-11; the tolerance below is far above both.
H = 1e-5
TOL = 1e-6


def _unary_model(mixture="softmax", readout="unary_probabilities", n=4, seed=0):
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    mix = {"softmax": SoftmaxMixture(K), "fixed": None,
           "moe": GatedMixture(n, K, seed=seed + 1)}[mixture]
    return DensityQNN(dec.sub_unitaries, mix, encoding=Encoding.unary(n), readout=readout,
                      seed=seed)


def _scalar(layer, x_shape):
    """``(x, *params) -> sum(w * layer(x))`` with fixed weights ``w``, and the names."""
    names = [n for n, _ in layer.named_parameters()]
    w = torch.linspace(-1.0, 1.5, int(np.prod(x_shape[:-1])) * 4, dtype=torch.float64)

    def f(x, *ps):
        out = torch.func.functional_call(layer, dict(zip(names, ps, strict=True)), (x,))
        return (out.reshape(-1) * w[:out.numel()]).sum()

    return f


def _fd_hessian(grad_fn, point: torch.Tensor) -> np.ndarray:
    """Central finite differences of ``grad_fn`` (a flat numpy gradient) at ``point``."""
    p = point.detach().clone()
    flat = p.reshape(-1)
    cols = []
    for j in range(flat.numel()):
        e = torch.zeros_like(flat)
        e[j] = H
        cols.append((grad_fn((flat + e).reshape(p.shape)) -
                     grad_fn((flat - e).reshape(p.shape))) / (2 * H))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize(("mixture", "readout"), [
    ("softmax", "unary_probabilities"), ("fixed", "unary_amplitudes"),
    ("softmax", "observable"), ("moe", "unary_probabilities"),
])
def test_hessians_on_the_torch_engine_equal_finite_differences(mixture, readout):
    model = _unary_model(mixture, readout)
    layer = DensityQNNLayer(model, engine="torch")
    exact = DensityQNNLayer(model, engine="exact")  # the oracle's gradients: numpy
    x = torch.rand(3, 4, dtype=torch.float64, generator=torch.Generator().manual_seed(1)) + 0.1
    f, g = _scalar(layer, x.shape), _scalar(exact, x.shape)
    params = tuple(p.detach().clone() for p in layer.parameters())
    for i, point in enumerate((x, *params)):  # each block: the input, then every parameter
        args = [x, *params]

        def at(v, i=i, args=args):
            return f(*[v if j == i else a for j, a in enumerate(args)])

        def grad_exact(v, i=i, args=args):
            vv = v.detach().clone().requires_grad_()
            return torch.autograd.grad(g(*[vv if j == i else a for j, a in enumerate(args)]),
                                       vv)[0].reshape(-1).numpy()

        Hs = hessian(at, point).reshape(point.numel(), point.numel()).numpy()
        assert np.abs(Hs).max() > 1e-3  # a real curvature, not the zeros of a silent path
        np.testing.assert_allclose(Hs, _fd_hessian(grad_exact, point), atol=TOL)
        np.testing.assert_allclose(Hs, Hs.T, atol=1e-12)


def test_mixed_second_derivative_input_and_angles_on_the_torch_engine():
    """d/dtheta of dL/dx (double backward through two different inputs) against finite
    differences in theta of the numpy engine's input gradient."""
    model = _unary_model("softmax", "unary_probabilities")
    layer, exact = DensityQNNLayer(model, engine="torch"), DensityQNNLayer(model)
    x = (torch.rand(2, 4, dtype=torch.float64, generator=torch.Generator().manual_seed(2))
         + 0.1).requires_grad_()
    v = torch.tensor([[0.3, -1.0, 0.5, 2.0], [1.0, 0.2, -0.7, 0.1]], dtype=torch.float64)
    (gx,) = torch.autograd.grad(layer(x).mul(v).sum(), x, create_graph=True)
    mixed = torch.autograd.functional.jacobian(
        lambda th: torch.autograd.grad(torch.func.functional_call(
            layer, {"theta": th, "logits": layer.logits}, (x,)).mul(v).sum(), x,
            create_graph=True)[0].reshape(-1), layer.theta.detach().clone())

    def gx_exact(th):
        with torch.no_grad():
            exact.theta.copy_(th)
        xx = x.detach().clone().requires_grad_()
        return torch.autograd.grad(exact(xx).mul(v).sum(), xx)[0].reshape(-1).numpy()

    np.testing.assert_allclose(gx.detach().reshape(-1).numpy(), gx_exact(layer.theta.detach()),
                               atol=1e-12)
    np.testing.assert_allclose(mixed.numpy(), _fd_hessian(gx_exact, layer.theta.detach()),
                               atol=TOL)


def test_the_unary_engine_forward_is_differentiable_to_any_order():
    """qdensity.execution.unary.forward on tensors that require a gradient: first derivatives
    equal the numpy engine's vjp, second ones finite differences of it, for shared and
    per-row angles and a single input run under every row; vjp and jacobian refuse such
    tensors instead of returning gradients that do not flow."""
    circ = pyramid(4)
    P = circ.num_parameters
    rng = np.random.default_rng(3)
    X, th, TH, gy = (rng.normal(size=(3, 4)), rng.normal(size=P), rng.normal(size=(3, P)),
                     rng.normal(size=(3, 4)))
    for xs, vs in ((X, th), (X, TH), (X[0], TH), (X[0], th)):
        xt = torch.tensor(xs).requires_grad_()
        vt = torch.tensor(vs).requires_grad_()
        y = unary.forward(circ, xt, vt)
        np.testing.assert_allclose(y.detach().numpy(), unary.forward(circ, xs, vs), atol=1e-13)
        w = torch.tensor(gy[:y.shape[0]] if y.ndim == 2 else gy[0])
        g_v, g_x = torch.autograd.grad((y * w).sum(), (vt, xt))
        ref_v, ref_x = unary.vjp(circ, xs, vs, w.numpy(), reduce="none")
        if np.ndim(xs) == 1 and np.ndim(vs) == 2:
            ref_x = ref_x.sum(axis=0)
        np.testing.assert_allclose(g_x.numpy(), ref_x, atol=1e-12)
        np.testing.assert_allclose(g_v.numpy(), ref_v.sum(axis=0) if ref_v.ndim > g_v.ndim
                                   else ref_v, atol=1e-12)
        Hv = hessian(lambda v, xt=xt, w=w: (unary.forward(circ, xt.detach(), v) * w).sum(),
                     vt.detach())
        n = vt.numel()

        def grad_np(v, xs=xs, w=w):
            gv = unary.vjp(circ, xs, v.numpy(), w.numpy(), reduce="sum")[0]
            return gv.reshape(-1) if v.ndim == 1 else unary.vjp(
                circ, xs, v.numpy(), w.numpy(), reduce="none")[0].reshape(-1)

        np.testing.assert_allclose(Hv.reshape(n, n).numpy(),
                                   _fd_hessian(grad_np, vt.detach()), atol=TOL)
    for xs in (X[0], X[:1]):  # one row: the columns are rotated in a copy, not in the input
        xt = torch.tensor(xs)
        unary.forward(circ, xt, torch.tensor(th))
        unary.vjp(circ, xt, torch.tensor(th), torch.ones_like(xt))
        assert torch.equal(xt, torch.tensor(xs))
    with pytest.raises(ValueError, match="vjp of the unary engine returns plain tensors"):
        unary.vjp(circ, X, torch.tensor(th, requires_grad=True), gy)
    with pytest.raises(ValueError, match="jacobian of the unary engine returns plain"):
        unary.jacobian(circ, X[0], torch.tensor(th, requires_grad=True))
    with torch.no_grad():  # under no_grad the tensors are plain values: allowed
        unary.vjp(circ, X, torch.tensor(th, requires_grad=True), gy)


def _angle_model():
    circ = hardware_efficient(3, 1, ("ry", "rz"))
    return DensityQNN(copies(circ, 2).sub_unitaries, SoftmaxMixture(2),
                      encoding=Encoding.angle(3), seed=2)


@pytest.mark.parametrize(("build", "engine", "where"), [
    (_unary_model, "exact", "the unary engine in numpy"),
    (_angle_model, "exact", "the adjoint statevector engine"),
    (_angle_model, "torch", "the adjoint statevector engine on torch"),
])
def test_second_derivatives_on_numpy_backward_paths_are_refused(build, engine, where):
    layer = DensityQNNLayer(build(), engine=engine)
    x = torch.rand(2, layer.num_features, dtype=torch.float64) + 0.2
    f = _scalar(layer, x.shape)
    params = tuple(p.detach().clone() for p in layer.parameters())
    message = rf"second derivatives .*{where}.*engine='torch'"
    with pytest.raises(RuntimeError, match=message):
        hessian(lambda th: f(x, th, *params[1:]), params[0])
    with pytest.raises(RuntimeError, match=message):
        hessian(lambda xx: f(xx, *params), x)
    # create_graph alone is not refused, and its first derivative is the plain one
    th = params[0].clone().requires_grad_()
    (g1,) = torch.autograd.grad(f(x, th, *params[1:]), th, create_graph=True)
    (g0,) = torch.autograd.grad(f(x, th, *params[1:]), th)
    torch.testing.assert_close(g1.detach(), g0, rtol=0, atol=1e-14)
    with pytest.raises(RuntimeError, match=message):
        torch.autograd.grad(g1.sum(), th)


def test_second_derivatives_of_sampled_gradients_are_refused():
    from qdensity.execution.sampler.engine import SamplerEngine

    layer = DensityQNNLayer(_unary_model(), engine=SamplerEngine(seed=0), shots=64)
    x = torch.rand(1, 4, dtype=torch.float64) + 0.2
    th = layer.theta.detach().clone().requires_grad_()
    out = torch.func.functional_call(layer, {"theta": th, "logits": layer.logits}, (x,))
    (g,) = torch.autograd.grad(out[:, 0].sum(), th, create_graph=True)
    with pytest.raises(RuntimeError, match=r"SamplerEngine.*engine='torch'"):
        torch.autograd.grad(g.sum(), th)


@pytest.mark.parametrize("engine", ["exact", "torch"])
def test_torch_compile_gives_the_eager_values_and_gradients(engine):
    layer = DensityQNNLayer(_unary_model(), engine=engine)
    x = torch.rand(3, 4, dtype=torch.float64) + 0.1
    compiled = torch.compile(layer, backend="eager")  # graph breaks around the quantum part
    out = compiled(x)
    out[:, 0].sum().backward()
    g = layer.theta.grad.clone()
    layer.zero_grad()
    ref = layer(x)
    ref[:, 0].sum().backward()
    torch.testing.assert_close(out, ref, rtol=0, atol=1e-13)
    torch.testing.assert_close(g, layer.theta.grad, rtol=0, atol=1e-13)


def test_the_adjoint_engine_refuses_values_that_require_a_gradient():
    """The adjoint engine's tensor results are plain tensors: values that require a gradient
    are refused rather than left without one; detached (or no_grad) values still run, and
    give the numpy rows' values."""
    from qdensity.execution.statevector.adjoint import AdjointEngine

    circ = hardware_efficient(2, 1)
    engine = AdjointEngine(backend="torch", device="cpu")
    v = torch.linspace(0.1, 0.9, circ.num_parameters, dtype=torch.float64)
    with pytest.raises(ValueError, match="values require a gradient"):
        engine.probabilities(circ, v.clone().requires_grad_())
    with torch.no_grad():
        p = engine.probabilities(circ, v.clone().requires_grad_())
    ref = AdjointEngine().probabilities(circ, v.numpy())
    np.testing.assert_allclose(np.asarray(p), ref, atol=1e-12)
