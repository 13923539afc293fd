"""Hyperparameter checks and model building for the scikit-learn estimators.

The estimators store their hyperparameters unvalidated (scikit-learn's rule); ``fit`` calls
:func:`check_hyperparameters`, which names the offending parameter, its value and what is
allowed, then :func:`build_model` turns the spec (``ansatz``, ``decomposition``, ``depth``,
``mixture``, ``readout``) or a :class:`DensityQNN` template into a fresh model.
"""

from __future__ import annotations

import copy

import numpy as np

from qdensity.circuits.ansatze.registry import FAMILIES, estimator_ansatze
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.density import METHODS as GRADIENTS
from qdensity.learning.optim import SGD, Adam, RMSprop
from qdensity.models.density import READOUTS, DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.registry import DECOMPOSITIONS, MIXTURES
from qdensity.validation import (
    MAX_ROWS,
    MAX_SHOTS,
    CallableC,
    Instance,
    Interval,
    Layers,
    Options,
    Qubits,
    Seed,
    SequenceOf,
    Unchecked,
    check_declared,
)

# The ansatz families, decompositions, mixtures, readouts and gradient methods are the
# registries' (circuits.ansatze.registry, models.registry, models.density, gradients.density),
# read at each check: a family registered there is an ``ansatz=`` value here.
OPTIMIZERS = {"adam": Adam, "sgd": SGD, "rmsprop": RMSprop}


_LAYER = ("None or a layer with forward, backward, params and grads ('linear' for post); "
          "checked by fit")

#: The estimators' hyperparameters, declared (scikit-learn's ``_parameter_constraints``):
#: checked by ``fit`` through :func:`check_hyperparameters`, never by the constructor.
PARAMETER_CONSTRAINTS = {
    "model": [Instance(DensityQNN, "DensityQNN template"), None],
    "ansatz": Options(estimator_ansatze), "decomposition": Options(lambda: DECOMPOSITIONS),
    "depth": Layers(), "mixture": Options(lambda: MIXTURES), "readout": Options(READOUTS),
    "num_qubits": [Qubits(2), None],
    "scale": Instance((bool, np.bool_), "bool (standardise the features before PCA and the "
                      "encoding)"),
    "constant": [Interval(float, 0, None, closed="neither"), None],
    "pre": Unchecked(_LAYER), "post": Unchecked(_LAYER),
    "optimizer": Options(tuple(OPTIMIZERS)),
    "learning_rate": Interval(float, 0, None, closed="neither"), "l2": Interval(float, 0),
    "epochs": Interval(int, 1, MAX_ROWS), "batch_size": Interval(int, 1, MAX_ROWS),
    "engine": [Options(("exact",)), Instance(SamplerEngine)],
    "shots": [Interval(int, 2, MAX_SHOTS, why="a sampled gradient estimates each circuit's "
                       "variance from its shots"), None],
    "gradient": Options(GRADIENTS),
    "max_steps": [Interval(int, 1), None], "max_shots": [Interval(int, 1), None],
    "seed": Seed(), "verbose": Instance((bool, np.bool_), "bool"),
    "callback": [CallableC("a callable (estimator, step)"), None],
    "callbacks": [SequenceOf(CallableC("a callable (estimator, record)"), min_len=0), None],
}


def check_hyperparameters(est) -> None:
    """Validate every hyperparameter of a QNN estimator (called at the start of ``fit``):
    each against :data:`PARAMETER_CONSTRAINTS`, then the ones that depend on each other."""
    check_declared(type(est).__name__, PARAMETER_CONSTRAINTS, est.get_params(deep=False))
    if isinstance(est.engine, SamplerEngine) and est.shots is None:
        raise ValueError("shots must be given (shots per circuit) with a SamplerEngine engine")
    for name in ("pre", "post"):
        layer = getattr(est, name)
        if layer is None or (name == "post" and isinstance(layer, str) and layer == "linear"):
            continue
        if isinstance(layer, str):
            raise ValueError(f"{name} must be 'linear', None or a layer, got {layer!r}")
        if not all(hasattr(layer, a) for a in ("forward", "backward", "params", "grads")):
            raise TypeError(f"{name} must have forward, backward, params and grads, got "
                            f"{type(layer).__name__}")


def encoded_width(est, num_features: int) -> tuple[int, int]:
    """``(num_qubits, data columns)``: qubit count follows the data unless ``num_qubits`` is set.

    With ``constant`` the last qubit carries that constant (so the norm of ``x`` and an
    all-zero row can be loaded); the other columns are the data, reduced by PCA or padded
    with zeros to fit ``num_qubits``.
    """
    if est.model is not None:
        n = est.model.num_qubits
        return n, n
    extra = 1 if est.constant is not None else 0
    n = est.num_qubits if est.num_qubits is not None else num_features + extra
    if n < 2:
        raise ValueError(f"a unary encoding needs at least 2 qubits; X has {num_features} "
                         f"feature(s) and constant=None: set constant or num_qubits >= 2")
    return n, n - extra


def build_model(est, num_qubits: int, rng: np.random.Generator) -> DensityQNN:
    """A fresh DensityQNN: a deep copy of the template, or one built from the spec."""
    if est.model is not None:
        model = copy.deepcopy(est.model)
        if model.num_parameters == 0 and model.mixture.num_params == 0:
            raise ValueError("model has no trainable parameters (no angles, fixed mixture)")
        return model
    family = FAMILIES[est.ansatz]
    allowed = READOUTS if family.readouts is None else tuple(family.readouts)
    if est.readout not in allowed:
        raise ValueError(f"readout must be one of {allowed} for ansatz {est.ansatz!r}, got "
                         f"{est.readout!r}")
    subs = DECOMPOSITIONS[est.decomposition].split(family.builder(num_qubits), est.depth)
    mixture = MIXTURES[est.mixture].build(num_qubits, len(subs), rng)
    return DensityQNN(subs, mixture, encoding=Encoding.unary(num_qubits), readout=est.readout,
                      seed=rng)


def make_optimizer(est):
    """The optimiser named by ``optimizer`` with ``learning_rate`` (SGD with momentum 0.9)."""
    if est.optimizer == "sgd":
        return SGD(lr=est.learning_rate, momentum=0.9)
    return OPTIMIZERS[est.optimizer](lr=est.learning_rate)
