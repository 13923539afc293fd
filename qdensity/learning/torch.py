"""A density QNN as a PyTorch module (optional extra: ``pip install "qdensity[torch]"``).

:class:`DensityQNNLayer` computes ``f(x) = sum_k alpha_k(x) f_k(x)`` (eq. 3) for a batch. The
sub-unitaries' outputs ``f_k`` come from qdensity (an ``autograd.Function``); the mixture
``alpha`` is ordinary torch: trainable softmax logits (eq. 2), a fixed distribution, or a
mixture-of-experts gate (Supp. H) -- the model's own ``GatedMixture`` copied into torch, or any
``torch.nn.Module`` you write that maps the input ``(B, d)`` to ``(B, K)`` probabilities.
Gradients reach the angles, the logits, the gate's weights and the input:

* ``engine="exact"`` on RBS/FBS models with a unary encoding: the unary engine's reverse mode,
  exact, with the gradient w.r.t. the input (through ``x / ||x||``), so classical layers before
  the quantum layer train (the paper's MNIST model, Fig. 11a);
* ``engine="exact"`` on every other model: the adjoint statevector engine
  (:mod:`qdensity.execution.statevector.adjoint`), one sweep per row for the angles and every
  data-carrying angle, chained to ``d/dx`` through the encoding's Jacobian and the re-uploaded
  features (:mod:`qdensity.gradients.inputs`), so classical layers train in front of angle-
  encoded, re-uploading and QCNN models too;
* a :class:`~qdensity.execution.engines.SamplerEngine` with ``shots`` per circuit: the
  model's gradient plans (parameter shift or commuting-generator circuits, Cor. 1 and 2),
  every shot on its ledger; when the input requires a gradient, also shift rules on the data
  parameters (:func:`~qdensity.gradients.inputs.input_gradient_plan`, in the same submission,
  its circuits and shots counted too): for an observable readout, and for unary probabilities
  the four-term RBS rule on the loader's angles chained with the loader's Jacobian
  ``d phi / d x``. Unary amplitudes (signs no measurement gives) have no sampled gradient.

Devices: the module computes on the device of its inputs (``layer.to("cuda")`` moves its
parameters). With ``engine="torch"``, or ``engine="exact"`` and inputs on a non-CPU device,
the quantum part runs on the torch engines there: the unary engine's torch path
(:mod:`qdensity.execution.unary`, tensors in and out, its reverse mode as the backward) for
RBS/FBS models, ``AdjointEngine(backend="torch", device=...)`` for every other model (the
parameter rows and results cross to the host; the states stay on the device). Same values as
``"exact"`` to rounding.

A gate's ``d alpha / d x`` is ordinary torch autograd, so a mixture-of-experts model gets the
whole input gradient of eq. 3 on every path.

Inputs may be ``(d,)``, ``(B, d)`` or ``(..., d)``; the output has the same leading shape.

Under ``torch.no_grad()`` the outputs are exact (no shots), as in the estimators' ``predict``.
Nothing in :mod:`qdensity` imports this module, so ``import qdensity`` never needs torch.
"""

from __future__ import annotations

import copy

import numpy as np
import torch
from torch import nn

from qdensity.execution.plans import Plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients._sparse import jacobian_vjp
from qdensity.gradients.density import METHODS, density_gradient_plan
from qdensity.gradients.inputs import input_gradient_plan, input_jacobians
from qdensity.models.density import DensityQNN
from qdensity.models.exact import exact_gradients, uses_unary_engine, z_readout_diagonal
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture
from qdensity.validation import (
    MAX_ROWS,
    MAX_SHOTS,
    MAX_SUBUNITARIES,
    Instance,
    Interval,
    Options,
    validates,
)

__all__ = ["DensityQNNLayer", "MoEGate"]


@validates(
    num_features=Interval(int, 1, MAX_ROWS), num_components=Interval(int, 1, MAX_SUBUNITARIES),
    activation=[Options(('gelu',)), None],
)
class MoEGate(nn.Module):
    """``alpha(x) = softmax(act(x W^T + b))``: the mixture-of-experts gate of Supp. H in torch.

    Parameters
    ----------
    num_features, num_components : int
        ``d`` and ``K``.
    activation : {None, "gelu"}
        None is the paper's "MoE", "gelu" its "MoE*" (exact erf GELU).

    Examples
    --------
    >>> import torch
    >>> from qdensity.learning.torch import MoEGate
    >>> _ = torch.manual_seed(0)
    >>> alpha = MoEGate(4, 3, activation="gelu")(torch.randn(5, 4, dtype=torch.float64))
    >>> tuple(alpha.shape), bool(torch.allclose(alpha.sum(dim=1), torch.ones(5).double()))
    ((5, 3), True)
    """

    def __init__(self, num_features: int, num_components: int, activation: str | None = None):
        super().__init__()
        self.linear = nn.Linear(num_features, num_components, dtype=torch.float64)
        self.activation = activation

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Input ``(B, d)`` -> mixture weights ``(B, K)`` on the simplex."""
        z = self.linear(x)
        if self.activation == "gelu":
            z = nn.functional.gelu(z)
        return torch.softmax(z, dim=-1)


#: Why a second derivative through the numpy engines is refused (they return plain arrays).
_SECOND_ORDER = (
    "second derivatives (Hessians, double backward, create_graph=True) of DensityQNNLayer are "
    "not available on the {path} path: its backward computes first derivatives in numpy, so "
    "autograd cannot differentiate them again. For RBS/FBS models with a unary encoding, "
    "DensityQNNLayer(model, engine='torch') differentiates to any order (the unary engine's "
    "torch path); otherwise use finite differences of the gradient")


class _Refused(torch.autograd.Function):
    """Returns ``outputs`` unchanged, tied to ``inputs`` on the tape; differentiating it
    raises ``message`` (a first derivative computed in numpy, asked for a second one)."""

    @staticmethod
    def forward(ctx, message, n, *tensors):
        ctx.message = message
        return tuple(t.clone() for t in tensors[:n])

    @staticmethod
    def backward(ctx, *grads):
        raise RuntimeError(ctx.message)


def _refuse_second_order(grads: tuple, inputs: tuple, path: str) -> tuple:
    """``grads`` (tensors or None) as they are, or -- while a backward builds a graph
    (``create_graph=True``) and an input requires a gradient -- tied to ``inputs`` through
    :class:`_Refused`, so that the second derivative raises instead of reading as zero."""
    if not torch.is_grad_enabled() or not any(
            isinstance(t, torch.Tensor) and t.requires_grad for t in inputs):
        return grads
    present = [g for g in grads if g is not None]
    tied = iter(_Refused.apply(_SECOND_ORDER.format(path=path), len(present), *present,
                               *[t for t in inputs if isinstance(t, torch.Tensor)]))
    return tuple(None if g is None else next(tied) for g in grads)


class _Experts(torch.autograd.Function):
    """``(x, theta) -> f_k(x)`` of every sub-unitary, shape (B, K, m), with its VJP (first
    derivatives only: a second one raises, see :data:`_SECOND_ORDER`)."""

    @staticmethod
    def forward(ctx, x, theta, layer, need_grad, engine=None):
        X = np.asarray(x.detach().cpu().numpy(), dtype=np.float64)
        th = np.array(theta.detach().cpu().numpy(), dtype=np.float64)  # a copy: steps change it
        outs, state = layer._run(X, th, need_grad=need_grad,
                                 need_input=need_grad and x.requires_grad, engine=engine)
        ctx.layer, ctx.state, ctx.theta = layer, state, th
        ctx.path = ("engine='torch' (the adjoint statevector engine on torch)"
                    if engine is not None else
                    f"{type(layer.engine).__name__} (sampled gradient circuits)"
                    if not isinstance(layer.engine, str) else
                    "engine='exact' (the unary engine in numpy)" if layer._unary else
                    "engine='exact' (the adjoint statevector engine)")
        ctx.save_for_backward(x, theta)
        return torch.from_numpy(outs).to(dtype=x.dtype, device=x.device)

    @staticmethod
    def backward(ctx, grad_outs):
        g = grad_outs.detach().cpu().numpy().astype(np.float64)
        g_theta, g_x = ctx.layer._vjp(ctx.state, ctx.theta, g, ctx.needs_input_grad[0])
        if ctx.needs_input_grad[0] and g_x is None:
            raise RuntimeError("the input gradient was not computed: the forward ran with an "
                               "input that did not require a gradient")
        gx = None if g_x is None else torch.from_numpy(g_x).to(grad_outs)
        gx, gt = _refuse_second_order((gx, torch.from_numpy(g_theta).to(grad_outs)),
                                      (*ctx.saved_tensors, grad_outs), ctx.path)
        return gx, gt, None, None, None


@torch.compiler.disable
def _experts(x, theta, layer, need_grad, engine):
    """:class:`_Experts` outside ``torch.compile``'s graphs (numpy work: a graph break)."""
    return _Experts.apply(x, theta, layer, need_grad, engine)


@torch.compiler.disable
def _unary_forward(compiled, x, theta):
    """The unary engine's torch path (differentiable to any order) outside ``torch.compile``'s
    graphs: its index tables and checks run eagerly (a graph break)."""
    from qdensity.execution.unary import forward

    return forward(compiled, x, theta)


@validates(
    model=Instance(DensityQNN),
    engine=[Options(('exact', 'torch')),
            Instance('qdensity.execution.sampler.engine:SamplerEngine')],
    shots=[Interval(int, 2, MAX_SHOTS), None], gradient=Options(METHODS),
    gate=[Instance(nn.Module, 'torch.nn.Module'), None],
)
class DensityQNNLayer(nn.Module):
    """A :class:`DensityQNN` as a ``torch.nn.Module``: input ``(..., d)`` -> output ``(..., m)``.

    Parameters
    ----------
    model : DensityQNN
        Copied; the module trains its own copy (:meth:`to_model` gives the trained model).
    engine : "exact", "torch" or SamplerEngine
        ``"exact"``: numpy engines for CPU inputs, the torch engines for inputs on another
        device; ``"torch"``: the torch engines always (module docstring).
    shots : int, optional
        Shots per circuit with a sampler engine.
    gradient : {"auto", "shift", "commuting"}
        Gradient circuits of the plan path.
    gate : torch.nn.Module, optional
        A mixture-of-experts gate ``(B, d) -> (B, K)`` that replaces the model's mixture.

    Attributes
    ----------
    theta : torch.nn.Parameter, shape (P,)
        The angles, in ``model.parameters`` order.
    logits : torch.nn.Parameter, shape (K,)
        With a softmax mixture.
    gate : torch.nn.Module or None
    shots_spent, circuits : int
        Totals run by this module on its engine.

    Examples
    --------
    >>> import torch
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import by_moments
    >>> from qdensity.models.mixtures import SoftmaxMixture
    >>> from qdensity.models import DensityQNN, Encoding
    >>> dec = by_moments(round_robin(4))
    >>> model = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries),
    ...                    encoding=Encoding.unary(4), readout="unary_probabilities", seed=0)
    >>> layer = DensityQNNLayer(model)
    >>> out = layer(torch.rand(5, 4, dtype=torch.float64))
    >>> out.shape, bool(torch.allclose(out.sum(dim=1), torch.ones(5, dtype=torch.float64)))
    (torch.Size([5, 4]), True)
    >>> out.sum().backward(); layer.theta.grad.shape
    torch.Size([6])
    """

    alpha: torch.Tensor  # a registered buffer (fixed mixture)

    def __init__(self, model: DensityQNN, *, engine="exact", shots: int | None = None,
                 gradient: str = "auto", gate: nn.Module | None = None):
        super().__init__()
        if isinstance(engine, SamplerEngine) and shots is None:
            raise ValueError("shots must be given (shots per circuit) with a SamplerEngine")
        self.model = copy.deepcopy(model)
        self.engine, self.shots, self.gradient = engine, shots, gradient
        self.shots_spent = self.circuits = 0
        mix = self.model.mixture
        self.theta = nn.Parameter(torch.tensor(self.model.theta, dtype=torch.float64))
        self.gate = gate
        if gate is None and isinstance(mix, SoftmaxMixture):
            self.logits = nn.Parameter(torch.tensor(mix.params, dtype=torch.float64))
        elif gate is None and isinstance(mix, GatedMixture):
            self.gate = MoEGate(mix.num_features, mix.num_components, mix.activation)
            with torch.no_grad():
                self.gate.linear.weight.copy_(torch.from_numpy(mix.weights))
                self.gate.linear.bias.copy_(torch.from_numpy(mix.bias))
        elif gate is None:
            self.register_buffer("alpha", torch.tensor(mix.alpha(None)[0], dtype=torch.float64))
        if not any(p.numel() for p in self.parameters() if p is not self.theta) and \
                self.model.num_parameters == 0:
            raise ValueError("model has no trainable parameters (no angles, fixed mixture)")
        if self.model.num_parameters == 0:
            self.theta.requires_grad_(False)
        # fixed per model, so found once: each sub-unitary's angles in theta, whether the
        # mixture is trivially alpha = 1 (one sub-unitary, no gate), the unary circuits
        K = self.model.num_subunitaries
        self._indices = [self.model.subunitary_parameter_indices(k) for k in range(K)]
        self._single = K == 1 and self.gate is None and (
            hasattr(self, "logits") or float(self.alpha[0]) == 1.0)
        self._unary = (engine in ("exact", "torch") and uses_unary_engine(self.model))
        if self._unary:  # the Givens rotations of each sub-unitary, extracted once
            from qdensity.execution.unary import compile_unary

            self._compiled = [compile_unary(c) for c in self.model.sub_unitaries]
            self._zdiag = (z_readout_diagonal(self.model.observable)
                           if self.model.readout == "observable" else None)

    @property
    def num_features(self) -> int:
        """``d``: the width of the input."""
        return self.model.num_features or self.model.num_qubits

    def mixture_weights(self, x: torch.Tensor) -> torch.Tensor:
        """``alpha(x)``, shape (B, K)."""
        if self.gate is not None:
            return self.gate(x)
        if hasattr(self, "logits"):
            return torch.softmax(self.logits, dim=0).expand(x.shape[0], -1)
        return self.alpha.to(x.dtype).expand(x.shape[0], -1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``f(x) = sum_k alpha_k(x) f_k(x)`` (eq. 3).

        Parameters
        ----------
        x : torch.Tensor, shape (d,), (B, d) or (..., d)
            Floating point.

        Returns
        -------
        torch.Tensor, shape (m,), (B, m) or (..., m)
            ``m = 1`` for an observable readout.
        """
        if not isinstance(x, torch.Tensor):
            raise TypeError(f"input must be a torch.Tensor, got {type(x).__name__}")
        if not x.is_floating_point():
            raise TypeError(f"input must be a floating-point tensor (float32 or float64), got "
                            f"dtype {x.dtype}")
        if x.ndim == 0 or x.shape[-1] != self.num_features or x.numel() == 0:
            raise ValueError(f"input must have shape (d,), (batch, d) or (..., d) with d = "
                             f"{self.num_features} and at least one row, got {tuple(x.shape)}")
        # (a meta tensor has shapes and no values: nothing to check)
        if x.device.type != "meta" and not bool(torch.isfinite(x).all()):
            raise ValueError("input must be finite (no NaN or inf)")
        lead = x.shape[:-1]
        flat = x.reshape(-1, self.num_features)
        need_grad = torch.is_grad_enabled() and (x.requires_grad or self.theta.requires_grad)
        on_torch = self.engine == "torch" or (self.engine == "exact" and flat.device.type != "cpu")
        if on_torch and self._unary:
            outs = self._unary_torch(flat)
        else:
            engine = self._torch_engine(flat.device) if on_torch else None
            outs = _experts(flat, self.theta, self, need_grad, engine)
        if self._single:  # alpha = 1: f = f_1, without mixing ops in the graph
            out = outs[:, 0]
        else:
            alpha = self.mixture_weights(flat).to(outs.dtype)
            out = torch.einsum("bk,bkm->bm", alpha, outs)
        return out.reshape(lead + out.shape[-1:])

    # ------------------------------------------------------------ torch engines
    def _unary_torch(self, flat: torch.Tensor) -> torch.Tensor:
        """``f_k(x)`` of every sub-unitary, (B, K, m), by the unary engine on ``flat``'s device."""
        norms = flat.norm(dim=1, keepdim=True)
        if flat.device.type != "meta" and bool((norms == 0).any()):
            rows = torch.nonzero(norms[:, 0] == 0).flatten().tolist()
            raise ValueError(f"input rows {rows} are all-zero; a unary encoding cannot load them")
        Xn = flat / norms
        readout = self.model.readout
        if readout == "observable":
            zdiag = torch.as_tensor(self._zdiag, dtype=flat.dtype, device=flat.device)
        outs = []
        for c, idx in zip(self._compiled, self._indices, strict=True):
            index = torch.as_tensor(np.asarray(idx, dtype=np.int64), device=flat.device)
            y = _unary_forward(c, Xn, self.theta.index_select(0, index).to(flat.dtype))
            if readout == "unary_amplitudes":
                outs.append(y)
            elif readout == "unary_probabilities":
                outs.append(y**2)
            else:
                outs.append((y**2 @ zdiag)[:, None])
        return torch.stack(outs, dim=1)

    def _torch_engine(self, device: torch.device):
        """The adjoint engine on ``device`` (one per device, kept with the module)."""
        from qdensity.execution.statevector.adjoint import AdjointEngine

        engines = self.__dict__.setdefault("_torch_engines", {})
        key = str(device)
        if key not in engines:
            engines[key] = AdjointEngine(backend="torch", device=device)
        return engines[key]

    # ------------------------------------------------------------ numpy side
    def _run(self, X, theta, *, need_grad: bool, need_input: bool = False, engine=None):
        m = self.model
        if engine is not None:  # the torch adjoint engine: every model but unary ones
            m.set_params(theta=theta)
            res = exact_gradients(m, X, engine, inputs=need_input)
            return res.outputs, ("adjoint", X, res)
        if self._unary:
            from qdensity.execution.unary import forward

            norms = np.linalg.norm(X, axis=1, keepdims=True)
            if not np.all(np.isfinite(norms)):
                rows = np.flatnonzero(~np.isfinite(norms[:, 0])).tolist()[:10]
                raise ValueError(f"input rows {rows} are not finite or too large (their norms "
                                 f"overflow float64); scale the input first")
            if np.any(norms == 0):
                rows = np.flatnonzero(norms[:, 0] == 0).tolist()
                raise ValueError(f"input rows {rows} are all-zero; a unary encoding cannot "
                                 f"load them")
            Xn = X / norms
            Ys = [forward(c, Xn, theta[idx])
                  for c, idx in zip(self._compiled, self._indices, strict=True)]
            if m.readout == "unary_amplitudes":
                outs = np.stack(Ys, axis=1)
            elif m.readout == "unary_probabilities":
                outs = np.stack([y**2 for y in Ys], axis=1)
            else:
                outs = np.stack([(y**2 @ self._zdiag)[:, None] for y in Ys], axis=1)
            return outs, ("unary", Xn, norms, Ys)
        m.set_params(theta=theta)
        if not need_grad:
            outs = m.expert_outputs(X)
            return (outs[:, :, None] if outs.ndim == 2 else outs), None
        if self.engine == "exact":  # the adjoint engine: angles and data columns in one sweep
            res = exact_gradients(m, X)
            return res.outputs, ("adjoint", X, res)
        engine = self.engine
        # sparse Jacobians: _vjp is their only reader (jacobian_vjp takes either layout)
        plans = [density_gradient_plan(m, X, method=self.gradient, shots=self.shots,
                                       jacobian="sparse")]
        if need_input:  # shift rules on the data parameters (the loader's angles too)
            plans.append(input_gradient_plan(m, X, shots=self.shots))
        plan = Plan.combine(plans, "density and input gradients")
        before = engine.ledger.total_shots if isinstance(engine, SamplerEngine) else 0
        answers = plan.run(engine)  # one submission
        self.circuits += plan.num_circuits
        grad = answers[0]
        inputs = [est.value for est in answers[1]] if need_input else None
        if isinstance(engine, SamplerEngine):
            self.shots_spent += engine.ledger.total_shots - before
        return grad.outputs, ("plan", grad, inputs)

    def _vjp(self, state, theta, g, need_input: bool = True):
        m = self.model
        g_theta = np.zeros(m.num_parameters)
        if state is None:
            raise RuntimeError("backward through outputs computed without gradients")
        if state[0] in ("plan", "adjoint"):
            jacobians = state[1].jacobians if state[0] == "plan" else state[2].jacobians
            for k, jac in enumerate(jacobians):
                np.add.at(g_theta, self._indices[k], jacobian_vjp(jac, g[:, k, :]))
            xjacs = (state[2] if state[0] == "plan"
                     else input_jacobians(m, state[1], state[2]) if need_input else None)
            if xjacs is None or not need_input:
                return g_theta, None
            return g_theta, sum(np.einsum("bm,bmd->bd", g[:, k, :], xj)
                                for k, xj in enumerate(xjacs))
        from qdensity.execution.unary import vjp

        _, Xn, norms, Ys = state
        g_Xn = np.zeros_like(Xn)
        for k, (c, y, idx) in enumerate(zip(self._compiled, Ys, self._indices, strict=True)):
            if m.readout == "unary_amplitudes":
                dY = g[:, k, :]
            elif m.readout == "unary_probabilities":
                dY = 2.0 * g[:, k, :] * y
            else:
                assert self._zdiag is not None  # set for an observable readout
                dY = 2.0 * g[:, k, :1] * self._zdiag[None, :] * y
            # start the reverse pass from the forward's outputs y (not run again)
            gv, gx = vjp(c, Xn, theta[idx], dY, reduce="sum", outputs=y)
            g_theta[idx] += gv  # a sub-unitary's parameters are distinct
            g_Xn += gx
        if not need_input:
            return g_theta, None
        return g_theta, (g_Xn - Xn * (Xn * g_Xn).sum(axis=1, keepdims=True)) / norms

    def to_model(self) -> DensityQNN:
        """A copy of the model with the trained angles (and softmax logits or MoE weights)."""
        out = copy.deepcopy(self.model)
        out.set_params(theta=self.theta.detach().cpu().numpy())
        if hasattr(self, "logits"):
            out.mixture.params = self.logits.detach().cpu().numpy()
        elif isinstance(self.gate, MoEGate) and isinstance(out.mixture, GatedMixture):
            w = self.gate.linear.weight.detach().cpu().numpy()
            b = self.gate.linear.bias.detach().cpu().numpy()
            out.mixture.params = np.concatenate([w.ravel(), b])
        elif self.gate is not None:
            raise ValueError("a custom torch gate has no DensityQNN counterpart; keep using the "
                             "module (or save its state_dict)")
        return out

    def extra_repr(self) -> str:
        engine = "exact" if self.engine == "exact" else type(self.engine).__name__
        return f"{self.model!r}, engine={engine}, shots={self.shots}"
