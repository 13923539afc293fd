"""Training density QNNs: a quantum layer between classical layers, losses, optimisers, history.

Estimators follow scikit-learn: hyper-parameters in the constructor, ``fit`` / ``predict`` /
``score``, learned state with a trailing underscore (``history_``, ``classes_``).

Two ways to get gradients:

* ``engine="exact"``: exact values. RBS/FBS models on a unary encoding use the unary engine's
  reverse mode (also giving gradients w.r.t. the inputs, so a trainable pre-processing layer
  works, Fig. 11); every other model uses the adjoint statevector engine
  (:mod:`qdensity.execution.adjoint`): one forward and one backward sweep per data row, with
  gradients w.r.t. the inputs too when the data enter as angles. Both engines, and the compiled
  circuits, live as long as the model. An :class:`~qdensity.engines.ExactEngine` passed as
  ``engine`` runs the exact gradient plans on Aer instead (each template transpiled once).
* ``engine=SamplerEngine(...)`` with ``shots``: every step runs the model's gradient plan
  (forward circuits plus parameter-shift or commuting-generator circuits) on the sampler with
  ``shots`` per circuit; circuits and shots are read off the engine's ledger.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from qdensity.execution.adjoint import AdjointEngine
from qdensity.execution.engines import ExactEngine, SamplerEngine
from qdensity.gradients.density import DensityGradient, chain_rule, density_gradient_plan
from qdensity.learning import losses as _losses
from qdensity.learning.nn import get_flat, load_parameters, save_parameters, set_flat
from qdensity.learning.optim import SGD, Adam
from qdensity.models.density import DensityQNN
from qdensity.models.exact import exact_gradients, unary_circuits
from qdensity.validation import as_rng, check_positive_int

__all__ = ["QuantumLayer", "History", "QNNClassifier", "QNNRegressor"]


class BudgetExhausted(RuntimeError):
    """Raised before a step whose circuits would exceed the shot budget."""


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
    """

    def __init__(self, model: DensityQNN, engine="exact", shots: int | None = None,
                 gradient: str = "auto"):
        self.model = model
        self.engine = engine
        self.shots = shots
        self.gradient = gradient
        self.grads: dict[str, np.ndarray] = {}
        self._cache = None
        self.circuits = 0
        self.shots_spent = 0
        self.max_shots: int | None = None
        if isinstance(engine, SamplerEngine):
            if shots is None:
                raise ValueError("a sampler engine needs shots (per circuit)")
            check_positive_int(shots, "shots")
        elif not (isinstance(engine, (AdjointEngine, ExactEngine)) or (
                isinstance(engine, str) and engine == "exact")):
            raise ValueError(f"engine must be 'exact', an AdjointEngine, an ExactEngine or a "
                             f"SamplerEngine, got {engine!r}")

    @property
    def params(self) -> dict[str, np.ndarray]:
        return {"theta": self.model.theta, "mixture": self.model.mixture.params}

    @property
    def analytic(self) -> bool:
        """True when exact unary reverse mode is used."""
        return self._is_exact_string() and self.model._use_unary()

    def _is_exact_string(self) -> bool:
        return isinstance(self.engine, str) and self.engine == "exact"

    @property
    def adjoint(self) -> bool:
        """True when the adjoint statevector engine gives values and gradients."""
        return isinstance(self.engine, AdjointEngine) or (
            self._is_exact_string() and not self.model._use_unary())

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
            self._cache = ("plan", Z, grad, res.input_jacobians)
            return np.einsum("bk,bkm->bm", alpha, res.outputs)
        plan = density_gradient_plan(self.model, Z, method=self.gradient, shots=self.shots)
        engine = self.engine
        cost = plan.total_shots
        if self.max_shots is not None and cost is not None and (
                self.shots_spent + cost > self.max_shots):
            left = self.max_shots - self.shots_spent
            raise BudgetExhausted(f"the next step needs {cost} shots; {left} remain")
        before = engine.ledger.total_shots if isinstance(engine, SamplerEngine) else 0
        grad = plan.run(engine)
        if isinstance(engine, SamplerEngine):
            self.shots_spent += engine.ledger.total_shots - before
        self.circuits += plan.num_circuits
        alpha = self.model.alpha(Z)
        self._cache = ("plan", Z, grad, None)
        return np.einsum("bk,bkm->bm", np.broadcast_to(alpha, grad.outputs.shape[:2]),
                         grad.outputs)

    def backward(self, grad_F: np.ndarray) -> np.ndarray | None:
        """Store ``grads["theta"]`` and ``grads["mixture"]``; return ``dL/dZ`` or None."""
        if self._cache is None:
            raise RuntimeError("backward called before forward")
        kind = self._cache[0]
        if kind == "plan":
            _, Z, grad, input_jacobians = self._cache
            g_theta, g_mix = chain_rule(self.model, Z, grad, grad_F)
            self.grads = {"theta": g_theta, "mixture": g_mix}
            if input_jacobians is None or self.model.mixture.data_dependent:
                return None
            alpha = np.broadcast_to(self.model.alpha(Z), grad.outputs.shape[:2])
            return sum(np.einsum("bm,bmd->bd", grad_F * alpha[:, k:k + 1], xj)
                       for k, xj in enumerate(input_jacobians))
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
            d = m._z_readout_matrix()
            outs = np.stack([(y**2 @ d)[:, None] for y in Ys], axis=1)
        self._cache = ("unary", Z, Xn, norms, Ys, outs, alpha)
        return np.einsum("bk,bkm->bm", alpha, outs)

    def _backward_unary(self, grad_F):
        from qdensity.execution.unary import vjp

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
                dY = 2.0 * a * grad_F[:, :1] * m._z_readout_matrix()[None, :] * y
            gv, gx = vjp(c, Xn, m._sub_theta(k, None), dY, reduce="sum")
            np.add.at(g_theta, m.subunitary_parameter_indices(k), gv)
            g_Xn += gx
        grad_alpha = np.einsum("bm,bkm->bk", grad_F, outs)
        self.grads = {"theta": g_theta, "mixture": m.mixture.vjp(Z, grad_alpha)}
        # through x / ||x||
        return (g_Xn - Xn * (Xn * g_Xn).sum(axis=1, keepdims=True)) / norms

    def set_params(self, theta, mixture) -> None:
        self.model.set_params(theta, mixture if np.size(mixture) else None)


@dataclass
class History:
    """Per-step record of training: loss, metric, circuits and shots (cumulative).

    Attributes
    ----------
    records : list of dict
        Keys ``step, epoch, loss, metric, circuits, shots``.
    """

    records: list[dict] = field(default_factory=list)

    def append(self, **row) -> None:
        self.records.append(row)

    def __getitem__(self, key: str) -> np.ndarray:
        return np.array([r[key] for r in self.records])

    def __len__(self) -> int:
        return len(self.records)


class _QNNEstimator:
    """Shared machinery of :class:`QNNClassifier` and :class:`QNNRegressor`."""

    _task = "regression"

    def __init__(self, model: DensityQNN, *, pre=None, post=None, optimizer: str = "adam",
                 learning_rate: float = 0.01, epochs: int = 10, batch_size: int = 32,
                 engine="exact", shots: int | None = None, gradient: str = "auto",
                 seed=None, verbose: bool = True, max_steps: int | None = None,
                 max_shots: int | None = None, callback=None):
        if not isinstance(model, DensityQNN):
            raise TypeError(f"model must be a DensityQNN, got {type(model).__name__}")
        if optimizer not in ("adam", "sgd"):
            raise ValueError(f"optimizer must be 'adam' or 'sgd', got {optimizer!r}")
        self.model = model
        self.pre = pre
        self.post = post
        self.optimizer = optimizer
        self.learning_rate = float(learning_rate)
        self.epochs = check_positive_int(epochs, "epochs")
        self.batch_size = check_positive_int(batch_size, "batch_size")
        self.engine = engine
        self.shots = shots
        self.gradient = gradient
        self.seed = seed
        self.verbose = verbose
        self.max_steps = max_steps
        self.max_shots = max_shots
        self.callback = callback

    # parameters as one flat vector: [pre..., theta, mixture, post...]
    def _parts(self):
        parts = []
        if self.pre is not None:
            parts.append(("pre", self.pre))
        parts.append(("quantum", self.layer_))
        if self.post is not None:
            parts.append(("post", self.post))
        return parts

    def _get(self) -> np.ndarray:
        return np.concatenate([get_flat(obj.params) for _, obj in self._parts()])

    def _grads(self) -> np.ndarray:
        return np.concatenate([get_flat(obj.grads) if obj.grads else np.zeros(
            get_flat(obj.params).size) for _, obj in self._parts()])

    def _set(self, flat: np.ndarray) -> None:
        i = 0
        for _, obj in self._parts():
            size = get_flat(obj.params).size
            chunk = flat[i:i + size]
            if obj is self.layer_:
                p = self.model.num_parameters
                obj.set_params(chunk[:p], chunk[p:])
            else:
                set_flat(obj, chunk)
            i += size

    def _forward(self, X, *, need_grad: bool = True):
        Z = self.pre.forward(X) if self.pre is not None else X
        F = self.layer_.forward(Z, need_grad=need_grad)
        return self.post.forward(F) if self.post is not None else F

    def _backward(self, grad_out):
        g = self.post.backward(grad_out) if self.post is not None else grad_out
        gz = self.layer_.backward(g)
        if self.pre is not None:
            if gz is None:
                raise ValueError("a trainable pre-processing layer needs input gradients, which "
                                 "only the exact unary engine provides; fix the pre layer or "
                                 "use engine='exact'")
            self.pre.backward(gz)

    def _targets(self, y):
        return np.asarray(y, dtype=float)

    def _loss(self, out, target):
        return _losses.mse(out[:, 0] if out.shape[1] == 1 and target.ndim == 1 else out, target)

    def _metric(self, out, target) -> float:
        return float(-self._loss(out, target)[0])

    def fit(self, X, y) -> _QNNEstimator:
        """Train on ``X`` (N, d), ``y`` (N,) with mini-batches; fills ``history_``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        target = self._targets(y)
        if target.shape[0] != X.shape[0]:
            raise ValueError(f"X has {X.shape[0]} rows but y has {target.shape[0]}")
        rng = as_rng(self.seed)
        self.layer_ = QuantumLayer(self.model, self.engine, self.shots, self.gradient)
        self.layer_.max_shots = self.max_shots
        self.stopped_by_budget_ = False
        opt = (Adam(lr=self.learning_rate) if self.optimizer == "adam"
               else SGD(lr=self.learning_rate, momentum=0.9))
        self.history_ = History()
        params = self._get()
        step = 0
        if self.callback is not None:
            self.callback(self, 0)
        for epoch in range(self.epochs):
            order = rng.permutation(X.shape[0])
            for start in range(0, X.shape[0], self.batch_size):
                idx = order[start:start + self.batch_size]
                try:
                    out = self._forward(X[idx])
                except BudgetExhausted:
                    self.stopped_by_budget_ = True
                    break
                loss, grad_out = self._loss(out, target[idx])
                self._backward(grad_out.reshape(out.shape))
                params = opt.step(params, self._grads())
                self._set(params)
                step += 1
                self.history_.append(step=step, epoch=epoch, loss=float(loss),
                                     metric=self._metric(out, target[idx]),
                                     circuits=self.layer_.circuits,
                                     shots=self.layer_.shots_spent)
                if self.verbose:
                    print(f"\r  epoch {epoch + 1}/{self.epochs} step {step} loss {loss:.4f}",
                          end="", file=sys.stderr, flush=True)
                if self.callback is not None:
                    self.callback(self, step)
                if self._done(step):
                    break
            if self._done(step):
                break
        if self.verbose:
            print(file=sys.stderr)
        return self

    def _done(self, step: int) -> bool:
        if self.stopped_by_budget_:
            return True
        return self.max_steps is not None and step >= self.max_steps

    def decision_function(self, X) -> np.ndarray:
        """Exact outputs of the trained pipeline (no shots), shape (N, m)."""
        if not hasattr(self, "layer_"):
            self.layer_ = QuantumLayer(self.model, "exact")
        saved = self.layer_.engine
        self.layer_.engine = "exact"
        try:
            return self._forward(np.atleast_2d(np.asarray(X, dtype=float)), need_grad=False)
        finally:
            self.layer_.engine = saved

    def save(self, path) -> None:
        """Save all trainable parameters to ``path`` (.npz or .json; never pickle)."""
        if not hasattr(self, "layer_"):
            self.layer_ = QuantumLayer(self.model, "exact")
        arrays = {name: get_flat(obj.params) for name, obj in self._parts()}
        save_parameters(path, **arrays)

    def load(self, path) -> _QNNEstimator:
        """Load parameters saved by :meth:`save` (shapes checked)."""
        if not hasattr(self, "layer_"):
            self.layer_ = QuantumLayer(self.model, "exact")
        data = load_parameters(path)
        flat = []
        for name, obj in self._parts():
            if name not in data:
                raise ValueError(f"{path} has no {name!r} parameters")
            want = get_flat(obj.params).size
            if data[name].size != want:
                raise ValueError(f"{name} parameters in {path} have {data[name].size} entries, "
                                 f"expected {want}")
            flat.append(data[name])
        self._set(np.concatenate(flat))
        return self


class QNNRegressor(_QNNEstimator):
    """Regression with squared error on the (post-processed) model output.

    ``predict`` returns shape (N,) for one output, else (N, m).
    """

    def predict(self, X) -> np.ndarray:
        out = self.decision_function(X)
        return out[:, 0] if out.shape[1] == 1 else out

    def score(self, X, y) -> float:
        """Coefficient of determination R^2."""
        y = np.asarray(y, dtype=float)
        pred = self.predict(X)
        return float(1 - ((y - pred) ** 2).sum() / ((y - y.mean()) ** 2).sum())


class QNNClassifier(_QNNEstimator):
    """Classification with cross-entropy on logits from ``post`` (or the raw outputs).

    ``classes_`` holds the sorted labels seen in ``fit``.
    """

    _task = "classification"

    def _targets(self, y):
        y = np.asarray(y)
        if not hasattr(self, "classes_") or getattr(self, "_fitting", False):
            self.classes_ = np.unique(y)
        lookup = {c: i for i, c in enumerate(self.classes_)}
        try:
            return np.array([lookup[v] for v in y], dtype=int)
        except KeyError as exc:
            raise ValueError(f"label {exc.args[0]!r} was not seen in fit") from exc

    def fit(self, X, y) -> QNNClassifier:
        self._fitting = True
        try:
            self.classes_ = np.unique(np.asarray(y))
            return super().fit(X, y)
        finally:
            self._fitting = False

    def _loss(self, out, target):
        return _losses.cross_entropy_with_logits(out, target)

    def _metric(self, out, target) -> float:
        return float(np.mean(out.argmax(axis=1) == target))

    def predict_proba(self, X) -> np.ndarray:
        from qdensity.models.mixtures import softmax

        return softmax(self.decision_function(X))

    def predict(self, X) -> np.ndarray:
        return self.classes_[self.decision_function(X).argmax(axis=1)]

    def score(self, X, y) -> float:
        """Accuracy."""
        return float(np.mean(self.predict(X) == np.asarray(y)))
