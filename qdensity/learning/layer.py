"""The quantum layer: a :class:`DensityQNN` with ``forward`` and ``backward`` (eq. 3, Cor. 1).

:class:`QuantumLayer` is the piece the scikit-learn estimators
(:mod:`qdensity.learning.estimators`) build on; :class:`History` is the per-step record of a
training run. Gradients:

* ``engine="exact"``: exact values. RBS/FBS models on a unary encoding use the unary engine's
  reverse mode (also giving gradients w.r.t. the inputs, so a trainable pre-processing layer
  works, Fig. 11); every other model uses the adjoint statevector engine
  (:mod:`~qdensity.execution.statevector`): one forward and one backward sweep per data row, with
  gradients w.r.t. the inputs too when the data enter as angles. Both engines, and the compiled
  circuits, live as long as the model. An :class:`~qdensity.execution.engines.ExactEngine` passed as
  ``engine`` runs the exact gradient plans on Aer instead (each template transpiled once).
* ``engine=SamplerEngine(...)`` with ``shots``: every step runs the model's gradient plan
  (forward circuits plus parameter-shift or commuting-generator circuits) on the sampler with
  ``shots`` per circuit; circuits and shots are read off the engine's ledger. With
  ``input_gradients=True`` (a trainable layer in front, as the estimators' ``pre``) every step
  also runs :func:`~qdensity.gradients.inputs.input_gradient_plan` (shift rules on the data
  parameters: the loader's RBS angles, an angle encoding's rotations, re-uploaded features),
  in the same submission, its circuits and shots on the ledger and under ``max_shots``.

Every path gives ``dL/dZ`` of eq. 3 in full, ``d alpha / d x`` times the sub-unitaries' outputs
included when the mixture depends on the data (:func:`~qdensity.gradients.inputs.input_vjp`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import Plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.statevector.adjoint import AdjointEngine
from qdensity.gradients.density import (
    METHODS,
    DensityGradient,
    chain_rule,
    density_gradient_plan,
)
from qdensity.gradients.inputs import input_gradient_plan, input_vjp
from qdensity.gradients.inputs import input_jacobians as _input_jacobians
from qdensity.models.density import DensityQNN
from qdensity.models.exact import (
    ExactGradients,
    exact_gradients,
    unary_circuits,
    uses_unary_engine,
    z_readout_diagonal,
)
from qdensity.validation import (
    MAX_SHOTS,
    Instance,
    Interval,
    Options,
    validates,
)

__all__ = ["QuantumLayer", "History", "BudgetExhausted"]


class BudgetExhausted(RuntimeError):
    """Raised before a step whose circuits would exceed the shot budget.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution.engines import SamplerEngine
    >>> from qdensity.learning import QuantumLayer
    >>> from qdensity.models import DensityQNN, Encoding
    >>> model = DensityQNN([round_robin(3)], encoding=Encoding.unary(3),
    ...                    readout="unary_probabilities", seed=0)
    >>> layer = QuantumLayer(model, SamplerEngine(seed=0, progress=False), shots=10)
    >>> layer.max_shots = 50  # nothing runs: the step's plan is priced first
    >>> layer.forward([[1.0, 2.0, 3.0]])
    Traceback (most recent call last):
    qdensity.learning.layer.BudgetExhausted: the next step needs ... shots; 50 remain
    """


@validates(
    model=Instance(DensityQNN),
    engine=[Options(('exact',)), Instance((AdjointEngine, ExactEngine, SamplerEngine),
                                          'AdjointEngine, ExactEngine or SamplerEngine')],
    shots=[Interval(int, 2, MAX_SHOTS), None], gradient=Options(METHODS),
    input_gradients=Instance((bool, np.bool_), 'bool'),
)
class QuantumLayer:
    """A :class:`DensityQNN` as a layer: ``forward(Z) -> F`` and ``backward(dL/dF) -> dL/dZ``.

    Parameters
    ----------
    model : DensityQNN
    engine : "exact", AdjointEngine, ExactEngine or SamplerEngine
        ``"exact"``: the unary engine for RBS models on unary inputs, else the model's own
        adjoint engine. An engine instance is kept for the layer's lifetime.
    shots : int, optional
        Shots per circuit with a sampler engine.
    gradient : {"auto", "shift", "commuting"}
        How gradient circuits are built for the sampled (or exact, non-unary) path.
    input_gradients : bool
        On the plan paths (a SamplerEngine or an ExactEngine): also run the input-gradient
        circuits in every forward with ``need_grad``, so that :meth:`backward` returns
        ``dL/dZ``; their circuits and shots count with the others (and against ``max_shots``).
        The exact and adjoint paths always return it.

    Examples
    --------
    Unary probabilities sum to 1 whatever the angles and the input, so ``L = sum F`` has zero
    gradient in both:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.learning import QuantumLayer
    >>> from qdensity.models import DensityQNN, Encoding
    >>> from qdensity.models.decompositions import by_moments
    >>> model = DensityQNN(by_moments(round_robin(3)).sub_unitaries, encoding=Encoding.unary(3),
    ...                    readout="unary_probabilities", seed=0)
    >>> layer = QuantumLayer(model)  # exact: the unary engine's reverse mode
    >>> F = layer.forward(np.array([[1.0, 2.0, 3.0], [0.5, -1.0, 2.0]]))
    >>> F.shape, bool(np.allclose(F.sum(axis=1), 1.0))
    ((2, 3), True)
    >>> dZ = layer.backward(np.ones((2, 3)))
    >>> bool(np.allclose(dZ, 0.0)), bool(np.allclose(layer.grads["theta"], 0.0))
    (True, True)
    """

    def __init__(self, model: DensityQNN, engine="exact", shots: int | None = None,
                 gradient: str = "auto", input_gradients: bool = False):
        self.input_gradients = bool(input_gradients)
        self.model = model
        self.engine = engine
        self.shots = shots
        self.gradient = gradient
        self.grads: dict[str, np.ndarray] = {}
        self._cache: tuple | None = None
        self.circuits = 0
        self.shots_spent = 0
        self.max_shots: int | None = None
        if isinstance(engine, SamplerEngine):
            if shots is None:
                raise ValueError("a sampler engine needs shots (per circuit)")

    @property
    def params(self) -> dict[str, np.ndarray]:
        return {"theta": self.model.theta, "mixture": self.model.mixture.params}

    @property
    def analytic(self) -> bool:
        """True when exact unary reverse mode is used."""
        return self._is_exact_string() and uses_unary_engine(self.model)

    def _is_exact_string(self) -> bool:
        return isinstance(self.engine, str) and self.engine == "exact"

    @property
    def adjoint(self) -> bool:
        """True when the adjoint statevector engine gives values and gradients."""
        return isinstance(self.engine, AdjointEngine) or (
            self._is_exact_string() and not uses_unary_engine(self.model))

    def forward(self, Z: np.ndarray, *, need_grad: bool = True) -> np.ndarray:
        """Model output for inputs ``Z`` (B, d) -> (B, m)."""
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        if self.analytic:
            return self._forward_unary(Z)
        if not need_grad and self._is_exact_string():
            out = self.model.predict(Z)
            return out[:, None] if out.ndim == 1 else out
        if self.adjoint:
            engine = self.engine if isinstance(self.engine, AdjointEngine) else None
            res = exact_gradients(self.model, Z, engine)
            zeros = np.zeros_like(res.outputs)
            grad = DensityGradient(res.outputs, zeros, res.jacobians,
                                   [np.zeros_like(j) for j in res.jacobians])
            alpha = np.broadcast_to(self.model.alpha(Z), res.outputs.shape[:2])
            self._cache = ("plan", Z, grad, res)
            return np.einsum("bk,bkm->bm", alpha, res.outputs)
        # sparse Jacobians: chain_rule is their only reader (O(B n) entries per unary
        # sub-unitary instead of B n P_k)
        plans = [density_gradient_plan(self.model, Z, method=self.gradient, shots=self.shots,
                                       jacobian="sparse")]
        if self.input_gradients and need_grad:  # shift rules on the data parameters, d f_k / d x
            plans.append(input_gradient_plan(self.model, Z, shots=self.shots))
        plan = Plan.combine(plans, "density and input gradients")
        engine = self.engine
        cost = plan.total_shots
        if self.max_shots is not None and cost is not None and (
                self.shots_spent + cost > self.max_shots):
            left = self.max_shots - self.shots_spent
            raise BudgetExhausted(f"the next step needs {cost} shots; {left} remain")
        before = engine.ledger.total_shots if isinstance(engine, SamplerEngine) else 0
        answers = plan.run(engine)  # one submission
        if isinstance(engine, SamplerEngine):
            self.shots_spent += engine.ledger.total_shots - before
        self.circuits += plan.num_circuits
        grad = answers[0]
        inputs = [est.value for est in answers[1]] if len(answers) > 1 else None
        alpha = self.model.alpha(Z)
        self._cache = ("plan", Z, grad, inputs)
        return np.einsum("bk,bkm->bm", np.broadcast_to(alpha, grad.outputs.shape[:2]),
                         grad.outputs)

    def backward(self, grad_F: np.ndarray) -> np.ndarray | None:
        """Store ``grads["theta"]`` and ``grads["mixture"]``; return ``dL/dZ``.

        Parameters
        ----------
        grad_F : numpy.ndarray, shape (B, m)
            ``dL/dF`` of the last :meth:`forward`.

        Returns
        -------
        numpy.ndarray, shape (B, d), or None
            ``dL/dZ`` (eq. 3 differentiated in the input, the data-dependent mixture's
            ``d alpha / dZ`` included); None on a plan path built without
            ``input_gradients``.
        """
        if self._cache is None:
            raise RuntimeError("backward called before forward")
        kind = self._cache[0]
        if kind == "plan":
            _, Z, grad, inputs = self._cache
            g_theta, g_mix = chain_rule(self.model, Z, grad, grad_F)
            self.grads = {"theta": g_theta, "mixture": g_mix}
            if inputs is None:
                return None
            if isinstance(inputs, ExactGradients):  # the adjoint sweep's data columns
                inputs = _input_jacobians(self.model, Z, inputs)
            return input_vjp(self.model, Z, grad.outputs, inputs, grad_F)
        return self._backward_unary(grad_F)

    # exact unary path ------------------------------------------------------------
    def _forward_unary(self, Z):
        from qdensity.execution.unary import forward

        m = self.model
        norms = np.linalg.norm(Z, axis=1, keepdims=True)
        if np.any(norms == 0):
            rows = np.flatnonzero(norms[:, 0] == 0).tolist()
            raise ValueError(f"inputs {rows} are all-zero; a unary encoding cannot load them")
        Xn = Z / norms
        Ys = [forward(c, Xn, m._sub_theta(k, None)) for k, c in enumerate(unary_circuits(m))]
        alpha = m.alpha(Z)
        alpha = np.broadcast_to(alpha, (Z.shape[0], m.num_subunitaries))
        if m.readout == "unary_amplitudes":
            outs = np.stack(Ys, axis=1)
        elif m.readout == "unary_probabilities":
            outs = np.stack([y**2 for y in Ys], axis=1)
        else:
            d = z_readout_diagonal(m.observable)
            outs = np.stack([(y**2 @ d)[:, None] for y in Ys], axis=1)
        self._cache = ("unary", Z, Xn, norms, Ys, outs, alpha)
        return np.einsum("bk,bkm->bm", alpha, outs)

    def _backward_unary(self, grad_F):
        from qdensity.execution.unary import vjp

        assert self._cache is not None  # backward checked it
        _, Z, Xn, norms, Ys, outs, alpha = self._cache
        m = self.model
        g_theta = np.zeros(m.num_parameters)
        g_Xn = np.zeros_like(Xn)
        for k, (c, y) in enumerate(zip(unary_circuits(m), Ys, strict=True)):
            a = alpha[:, k:k + 1]
            if m.readout == "unary_amplitudes":
                dY = a * grad_F
            elif m.readout == "unary_probabilities":
                dY = 2.0 * a * grad_F * y
            else:
                dY = 2.0 * a * grad_F[:, :1] * z_readout_diagonal(m.observable)[None, :] * y
            # the reverse pass starts from the forward's outputs y (not run again)
            gv, gx = vjp(c, Xn, m._sub_theta(k, None), dY, reduce="sum", outputs=y)
            np.add.at(g_theta, m.subunitary_parameter_indices(k), gv)
            g_Xn += gx
        grad_alpha = np.einsum("bm,bkm->bk", grad_F, outs)
        self.grads = {"theta": g_theta, "mixture": m.mixture.vjp(Z, grad_alpha)}
        # through x / ||x||, plus d alpha / dZ of a data-dependent mixture (zero otherwise)
        return ((g_Xn - Xn * (Xn * g_Xn).sum(axis=1, keepdims=True)) / norms
                + m.mixture.input_vjp(Z, grad_alpha))

    def set_params(self, theta, mixture) -> None:
        self.model.set_params(theta, mixture if np.size(mixture) else None)


@validates(records=Instance(list), epochs=Instance(list))
@dataclass
class History:
    """Per-step record of training: loss, metric, circuits and shots (cumulative).

    Attributes
    ----------
    records : list of dict
        Keys ``step, epoch, loss, metric, circuits, shots``.
    epochs : list of dict
        One per finished epoch (filled by the estimators): ``epoch, step, train_loss,
        train_metric, circuits, shots, seconds`` and ``test_metric`` with an ``eval_set``.

    Examples
    --------
    >>> from qdensity.learning import History
    >>> history = History()
    >>> history.append(step=1, loss=0.5); history.append(step=2, loss=0.25)
    >>> len(history), history["loss"].tolist()
    (2, [0.5, 0.25])
    """

    records: list[dict] = field(default_factory=list)
    epochs: list[dict] = field(default_factory=list)

    def append(self, **row) -> None:
        self.records.append(row)

    def __getitem__(self, key: str) -> np.ndarray:
        return np.array([r[key] for r in self.records])

    def __len__(self) -> int:
        return len(self.records)
