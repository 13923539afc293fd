"""scikit-learn estimators for density QNNs: :class:`QNNClassifier` and :class:`QNNRegressor`.

They behave like scikit-learn's own (``clone``, ``Pipeline``, ``GridSearchCV``,
``cross_val_score``, ``check_estimator``): the constructor stores hyperparameters only;
``fit`` validates them, builds a fresh model and trains it; learned state ends in ``_``
(``model_``, ``classes_``, ``n_features_in_``, ``history_``, ``layer_``, ``pca_``).

The model is given either as a spec (``ansatz``, ``decomposition``, ``depth``, ``mixture``,
``readout``; the unary encoding of eq. 1 on ``num_qubits`` qubits) or as a :class:`DensityQNN`
template, which ``fit`` deep-copies and never mutates. A spec model encodes the data in three
steps, all fitted in ``fit`` and applied by :meth:`~QNNClassifier.transform`: standardisation
(``scale=True``, kept in ``scaler_``), then PCA to ``num_qubits - 1`` columns when
``num_qubits`` is set and smaller than the features (kept in ``pca_``; zero padding when
larger), then a constant qubit. The qubit count follows the data:
``n = n_features + 1`` (the last qubit carries ``constant``, so that the norm of ``x`` reaches
the model and an all-zero row can be loaded; ``constant=None`` drops it); ``num_qubits=6``
means PCA to 5 features plus the constant qubit. ``fit`` logs the mapping (logger
``qdensity.learning.estimators``, level INFO).

``predict``, ``predict_proba`` and ``decision_function`` are exact whatever engine trained
the model; :meth:`~QNNClassifier.estimate` samples the same answer with shots on a
:class:`~qdensity.execution.engines.SamplerEngine` and returns standard errors.

The output of the model (eq. 3: ``f(x) = sum_k alpha_k(x) f_k(x)``, unary probabilities by
default) goes through a linear read-out (``post="linear"``, the ``n -> classes`` layer of
Fig. 11a) to logits (classifier, cross entropy) or predictions (regressor, squared error).
Gradients come from :class:`~qdensity.learning.layer.QuantumLayer`: exact unary reverse mode
for RBS models, or gradient plans through any engine with ``shots`` written to the ledger. A
trainable ``pre`` layer gets ``dL/dx`` on every engine: exactly, or from shift rules on the
data parameters (the loader's RBS angles) run with the same ``shots`` and on the same ledger.
"""

from __future__ import annotations

import copy
import logging
import time

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, RegressorMixin
from sklearn.decomposition import PCA
from sklearn.preprocessing import StandardScaler
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import validate_data

from qdensity.execution.plans import Estimate
from qdensity.learning import losses as _losses
from qdensity.learning._encoding import (
    EncodingMixin,
    UnscaledFeaturesWarning,
    _naming,
    warn_if_unscaled,
)
from qdensity.learning._estimate import EstimateMixin, fit_engine
from qdensity.learning._saved import FORMAT_VERSION, SavedMixin
from qdensity.learning._spec import (
    PARAMETER_CONSTRAINTS,
    build_model,
    check_hyperparameters,
    encoded_width,
    make_optimizer,
)
from qdensity.learning.layer import BudgetExhausted, History, QuantumLayer
from qdensity.learning.nn import Linear
from qdensity.learning.parameters import get_flat, set_flat
from qdensity.models.mixtures import softmax
from qdensity.progress import progress_bar
from qdensity.validation import as_rng, check_magnitude

__all__ = ["QNNClassifier", "QNNRegressor", "FORMAT_VERSION", "UnscaledFeaturesWarning"]

_LOG = logging.getLogger(__name__)


class _QNNEstimator(EncodingMixin, EstimateMixin, SavedMixin, BaseEstimator):
    """Shared machinery; see :class:`QNNClassifier` for the parameters."""

    #: The hyperparameters, declared; ``fit`` checks them (scikit-learn's convention).
    _parameter_constraints = PARAMETER_CONSTRAINTS

    def __init__(self, model=None, *, ansatz="round_robin", decomposition="layers", depth=1,
                 mixture="softmax", readout="unary_probabilities", num_qubits=None,
                 constant=1.0, scale=True, pre=None, post="linear", optimizer="adam",
                 learning_rate=0.05, l2=0.0, epochs=10, batch_size=32, engine="exact", shots=None,
                 gradient="auto", max_steps=None, max_shots=None, seed=0, verbose=True,
                 callback=None, callbacks=None):
        self.model = model
        self.ansatz = ansatz
        self.decomposition = decomposition
        self.depth = depth
        self.mixture = mixture
        self.readout = readout
        self.num_qubits = num_qubits
        self.constant = constant
        self.scale = scale
        self.pre = pre
        self.post = post
        self.optimizer = optimizer
        self.learning_rate = learning_rate
        self.l2 = l2
        self.epochs = epochs
        self.batch_size = batch_size
        self.engine = engine
        self.shots = shots
        self.gradient = gradient
        self.max_steps = max_steps
        self.max_shots = max_shots
        self.seed = seed
        self.verbose = verbose
        self.callback = callback
        self.callbacks = callbacks

    # ---------------------------------------------------------------- the data path
    def _parts(self):
        parts = [] if self.pre_ is None else [self.pre_]
        parts.append(self.layer_)
        return parts + ([] if self.post_ is None else [self.post_])

    def _get(self) -> np.ndarray:
        return np.concatenate([get_flat(p.params) for p in self._parts()])

    def _grads(self) -> np.ndarray:
        return np.concatenate([get_flat(p.grads) if p.grads else np.zeros(get_flat(p.params).size)
                               for p in self._parts()])

    def _set(self, flat: np.ndarray) -> None:
        i = 0
        for part in self._parts():
            size = get_flat(part.params).size
            chunk = flat[i:i + size]
            if part is self.layer_:
                p = self.model_.num_parameters
                part.set_params(chunk[:p], chunk[p:])
            else:
                set_flat(part, chunk)
            i += size

    def _forward(self, Z, layer=None, *, need_grad: bool = True) -> np.ndarray:
        layer = self.layer_ if layer is None else layer
        if self.pre_ is not None:
            Z = self.pre_.forward(Z)
        F = layer.forward(Z, need_grad=need_grad)
        return self.post_.forward(F) if self.post_ is not None else F

    def _backward(self, grad_out) -> None:
        g = self.post_.backward(grad_out) if self.post_ is not None else grad_out
        gz = self.layer_.backward(g)
        if self.pre_ is not None:
            if gz is None:  # a layer built without input_gradients (fit builds it with them)
                raise ValueError("a trainable pre-processing layer needs input gradients; "
                                 "build the QuantumLayer with input_gradients=True")
            self.pre_.backward(gz)

    def _outputs(self, X) -> np.ndarray:
        """Exact outputs of the fitted pipeline for raw ``X`` (no shots), shape (N, m)."""
        Z = self.transform(X)  # checks that the estimator is fitted
        return self._forward(Z, QuantumLayer(self.model_, "exact"), need_grad=False)

    # ---------------------------------------------------------------- fit
    def _prepare(self, X, rng, *, fit_pca: bool = True):
        n, cols = encoded_width(self, X.shape[1])
        self.num_qubits_, self._data_columns_ = n, cols
        self.pca_ = self.scaler_ = None
        if self.model is None and self.scale and fit_pca:
            self.scaler_ = StandardScaler().fit(X)
            X = self.scaler_.transform(X)
        if self.model is None and cols < X.shape[1] and fit_pca:
            self.pca_ = PCA(n_components=cols, svd_solver="full").fit(X)
        elif self.model is not None and X.shape[1] != self.model.num_features:
            raise ValueError(f"X has {X.shape[1]} features but the model template takes "
                             f"{self.model.num_features} (its encoding's or the data it "
                             f"uploads, x[0] .. x[d - 1])")
        self.model_ = build_model(self, n, rng)
        width = self.model_.num_qubits if self.model_.readout != "observable" else 1
        self.pre_ = copy.deepcopy(self.pre) if self.pre is not None else None
        if isinstance(self.post, str):
            self.post_: Linear | None = Linear(width, self._num_targets, seed=rng)
        elif self.post is None:
            if width != self._num_targets:
                raise ValueError(f"post=None needs the model's {width} output(s) to equal the "
                                 f"{self._num_targets} targets; add a read-out head (post='linear'"
                                 ") or one output per class (readout='unary_probabilities')")
            self.post_ = None
        else:
            self.post_ = copy.deepcopy(self.post)

    def fit(self, X, y, *, eval_set=None):
        """Train on ``X`` (N, d), ``y`` (N,) with mini-batches; fills ``history_``.

        Parameters
        ----------
        X : array_like, shape (N, d)
        y : array_like, shape (N,) (regressor: or (N, m))
        eval_set : tuple (X_test, y_test), optional
            Scored exactly at the end of every epoch (``history_.epochs[i]["test_metric"]``).

        Returns
        -------
        self
        """
        check_hyperparameters(self)
        with _naming("X and y"):
            X, target = self._validate_xy(X, y)
        check_magnitude(X, "X", "scale the features first (e.g. a Pipeline with "
                         "StandardScaler)")
        if eval_set is not None:
            if not isinstance(eval_set, (tuple, list)) or len(eval_set) != 2:
                raise ValueError("eval_set must be a pair (X_test, y_test)")
        if self.model is not None or not self.scale:
            warn_if_unscaled(X, f"{type(self).__name__}.fit(X)")
        rng = as_rng(self.seed)
        self._prepare(X, rng)
        _LOG.info("%s: %s", type(self).__name__, self.encoding_description())
        Z = self._encode(X)
        self.layer_ = QuantumLayer(self.model_, fit_engine(self.engine, self.seed), self.shots,
                                   self.gradient, input_gradients=self.pre_ is not None)
        self.layer_.max_shots = self.max_shots
        self.stopped_by_budget_ = False
        opt = make_optimizer(self)
        self.history_ = History()
        params = self._get()
        step, stop = 0, False
        if self.callback is not None:
            self.callback(self, 0)
        steps_per_epoch = -(-X.shape[0] // self.batch_size)
        total = steps_per_epoch * self.epochs
        if self.max_steps is not None:
            total = min(total, self.max_steps)
        t0 = time.perf_counter()
        with progress_bar(total, desc=type(self).__name__, verbose=self.verbose,
                          unit="step") as bar:
            for epoch in range(self.epochs):
                order = rng.permutation(X.shape[0])
                losses, metrics = [], []
                for start in range(0, X.shape[0], self.batch_size):
                    idx = order[start:start + self.batch_size]
                    try:
                        out = self._forward(Z[idx])
                    except BudgetExhausted:
                        self.stopped_by_budget_ = stop = True
                        break
                    loss, grad_out = self._loss(out, target[idx])
                    self._backward(grad_out.reshape(out.shape))
                    grads = self._grads()
                    if self.l2:
                        pen, g_pen = _losses.l2_penalty(params, float(self.l2))
                        loss, grads = loss + pen, grads + g_pen
                    params = opt.step(params, grads)
                    self._set(params)
                    step += 1
                    metric = self._metric(out, target[idx])
                    losses.append(float(loss))
                    metrics.append(metric)
                    self.history_.append(step=step, epoch=epoch, loss=float(loss), metric=metric,
                                         circuits=self.layer_.circuits,
                                         shots=self.layer_.shots_spent)
                    bar.set_postfix(loss=f"{loss:.4f}", metric=f"{metric:.3f}",
                                    shots=self.layer_.shots_spent, refresh=False)
                    bar.update(1)
                    if self.callback is not None:
                        self.callback(self, step)
                    if self.max_steps is not None and step >= self.max_steps:
                        stop = True
                        break
                if losses:
                    stop = self._end_epoch(epoch, step, losses, metrics, eval_set, t0) or stop
                if stop:
                    break
        return self

    def _end_epoch(self, epoch, step, losses, metrics, eval_set, t0) -> bool:
        record = {"epoch": epoch, "step": step, "train_loss": float(np.mean(losses)),
                  "train_metric": float(np.mean(metrics)), "circuits": self.layer_.circuits,
                  "shots": self.layer_.shots_spent, "seconds": time.perf_counter() - t0}
        if eval_set is not None:
            record["test_metric"] = float(self.score(*eval_set))
        self.history_.epochs.append(record)
        stop = False
        for cb in self.callbacks or ():
            stop = bool(cb(self, record)) or stop
        return stop

    # ---------------------------------------------------------------- persistence
    def _meta(self) -> dict:
        return {}

    def _load_meta(self, meta) -> None:
        pass


class QNNClassifier(ClassifierMixin, _QNNEstimator):
    """Density-QNN classifier: cross entropy on logits from a linear read-out (Fig. 11a).

    Parameters
    ----------
    model : DensityQNN, optional
        A template that ``fit`` deep-copies (never mutated); overrides the spec below.
    ansatz : {"round_robin", "pyramid", "x", "butterfly"} or another registered family
        Hamming-weight-preserving RBS circuit on ``n`` qubits (butterfly: ``n`` a power of 2):
        a family of :data:`~qdensity.circuits.ansatze.registry.FAMILIES` registered with
        ``estimator=True``.
    decomposition : {"layers", "cyclic", "odd_even", "none"}
        Sub-unitaries: ``depth`` moments each ("layers", Fig. 3), ``depth`` cyclic moments
        ("cyclic", Fig. 6), odd/even gates, or the pure model ("none", K = 1); the entries of
        :data:`~qdensity.models.registry.DECOMPOSITIONS`.
    depth : int
        Moments per sub-unitary.
    mixture : {"softmax", "fixed", "moe", "moe_gelu"}
        Trainable alpha (eq. 2), uniform fixed alpha, or a data-dependent gate (Supp. H).
    readout : {"unary_probabilities", "unary_amplitudes", "observable"}
    num_qubits : int, optional
        Width of the model; the data are PCA-reduced (or zero-padded) to fit.
    constant : float or None
        Value loaded on the last qubit (None: no extra qubit).
    scale : bool
        Standardise the features (``StandardScaler``, fitted in ``fit``) before PCA and the
        encoding; spec models only (a template takes the data as given). Without it,
        features whose spreads differ by orders of magnitude raise
        :class:`UnscaledFeaturesWarning`.
    pre : layer, optional
        A numpy layer before the encoding, trained on every engine: with a sampler, each step
        also runs the input-gradient circuits (shift rules on the data parameters,
        :func:`~qdensity.gradients.inputs.input_gradient_plan`) with ``shots`` each, on the
        ledger and under ``max_shots``; ``readout="unary_amplitudes"`` trains exactly only.
        For classical networks, use the PyTorch layer :mod:`qdensity.learning.torch`.
    post : "linear", None or a layer
        Read-out to logits (``"linear"``: ``outputs -> classes``, Glorot initialised).
    optimizer : {"adam", "sgd", "rmsprop"}
    learning_rate : float
        ``> 0``.
    l2 : float
        ``>= 0``; adds ``l2 * ||params||^2`` to the loss.
    epochs, batch_size : int
    engine : "exact" or SamplerEngine
        A sampler engine spends ``shots`` per circuit; its ledger records them. A seeded
        engine is not advanced by ``fit``: each fit draws from ``engine.with_seed(...)``,
        seeded by the engine's seed and ``seed``, so a refit gives the same model. A clone
        (``sklearn.base.clone``, ``GridSearchCV``, ``cross_val_score``) gets a copy of the
        engine and its ledger: the shots of a search are on each fitted clone's
        ``engine.ledger`` (``search.best_estimator_.engine.ledger`` for the refit), not on
        the ledger of the engine passed in.
    shots : int, optional
        Needed with a sampler engine.
    gradient : {"auto", "shift", "commuting"}
    max_steps, max_shots : int, optional
        Stop after this many steps / before exceeding this many shots.
    seed : int, Generator or None
        Initial parameters and batch order (default 0: refits are identical).
    verbose : bool
        A tqdm bar (loss, metric, shots) when attached to a terminal.
    callback : callable, optional
        ``callback(estimator, step)`` after every step (and with step 0 before training).
    callbacks : list of callable, optional
        ``cb(estimator, record)`` after every epoch; ``record`` holds ``epoch, step,
        train_loss, train_metric, circuits, shots, seconds`` (and ``test_metric`` with
        ``eval_set``); a callback returning True stops training.

    Attributes
    ----------
    classes_ : numpy.ndarray, shape (C,)
    model_ : DensityQNN
    layer_ : QuantumLayer
    history_ : History
        Per step (``history_["loss"]``) and per epoch (``history_.epochs``).
    n_features_in_, num_qubits_ : int
        ``num_qubits_ = num_qubits`` if set, else ``n_features_in_ + 1`` (the constant
        qubit; ``num_qubits=6`` on 30 features: PCA to 5 plus the constant).
    scaler_ : sklearn.preprocessing.StandardScaler or None
    pca_ : sklearn.decomposition.PCA or None

    Examples
    --------
    >>> from sklearn.datasets import load_iris
    >>> X, y = load_iris(return_X_y=True)
    >>> clf = QNNClassifier(epochs=5, learning_rate=0.1, verbose=False).fit(X, y)
    >>> clf.num_qubits_, clf.classes_.tolist()
    (5, [0, 1, 2])
    >>> bool(clf.score(X, y) > 0.6)
    True
    """

    _num_targets = 2

    def _validate_xy(self, X, y):
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        self.classes_, target = np.unique(y, return_inverse=True)
        if self.classes_.size < 2:
            raise ValueError(f"{type(self).__name__} needs samples of at least 2 classes in "
                             f"the data, but the data contains only one class: "
                             f"{self.classes_[0]!r}")
        self._num_targets = self.classes_.size
        return X, target

    def _loss(self, out, target):
        return _losses.cross_entropy_with_logits(out, target)

    def _metric(self, out, target) -> float:
        return float(np.mean(out.argmax(axis=1) == target))

    def decision_function(self, X) -> np.ndarray:
        """Logits, shape (N, C); for two classes the margin ``l_1 - l_0``, shape (N,).
        Exact, whatever engine trained the model."""
        out = self._outputs(X)
        return out[:, 1] - out[:, 0] if out.shape[1] == 2 else out

    def predict_proba(self, X) -> np.ndarray:
        """Class probabilities ``softmax(logits)``, shape (N, C).

        Exact (the unary or statevector engine), whatever engine trained the model; for a
        sampled answer with standard errors use :meth:`estimate`.
        """
        return softmax(self._outputs(X))

    def predict(self, X) -> np.ndarray:
        """Labels from ``classes_``, shape (N,).

        Exact, whatever engine trained the model (see :meth:`estimate` for shots).
        """
        out = self._outputs(X)
        return self.classes_[out.argmax(axis=1)]

    def _meta(self) -> dict:
        kind = self.classes_.dtype.kind
        return {"classes": self.classes_.tolist(), "classes_kind": kind}

    def _load_meta(self, meta) -> None:
        self.classes_ = np.array(meta["classes"])
        self._num_targets = self.classes_.size


class QNNRegressor(RegressorMixin, _QNNEstimator):
    """Density-QNN regressor: squared error on a linear read-out of the model's outputs.

    Parameters are those of :class:`QNNClassifier`. ``predict`` returns shape (N,) for a 1-d
    target, (N, m) for an (N, m) target; ``score`` is R^2.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.random.default_rng(0).normal(size=(60, 3))
    >>> reg = QNNRegressor(epochs=20, learning_rate=0.1, verbose=False).fit(X, X[:, 0])
    >>> reg.predict(X).shape
    (60,)
    """

    _num_targets = 1

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        return tags

    def _validate_xy(self, X, y):
        X, y = validate_data(self, X, y, dtype=np.float64, y_numeric=True, multi_output=True)
        y = np.asarray(y, dtype=float)
        check_magnitude(y, "y", "wrap the estimator in sklearn.compose.TransformedTargetRegressor"
                         "(regressor, transformer=StandardScaler())")
        self._target_ndim_ = y.ndim
        self._num_targets = 1 if y.ndim == 1 else y.shape[1]
        return X, y

    def _loss(self, out, target):
        return _losses.mse(out[:, 0] if target.ndim == 1 else out, target)

    def _metric(self, out, target) -> float:
        return -float(self._loss(out, target)[0])

    def predict(self, X) -> np.ndarray:
        """Predictions, shape (N,) or (N, m).

        Exact (the unary or statevector engine), whatever engine trained the model; for a
        sampled answer with standard errors use :meth:`estimate`.
        """
        out = self._outputs(X)
        return out[:, 0] if self._target_ndim_ == 1 else out

    def _shape_estimate(self, est: Estimate) -> Estimate:
        if self._target_ndim_ == 1:
            return Estimate(est.value[:, 0], est.standard_error[:, 0])
        return est

    def _meta(self) -> dict:
        return {"target_ndim": self._target_ndim_, "num_targets": self._num_targets}

    def _load_meta(self, meta) -> None:
        self._target_ndim_ = meta["target_ndim"]
        self._num_targets = meta["num_targets"]
