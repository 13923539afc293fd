"""Hyperparameter checks and model building for the scikit-learn estimators.

The estimators store their hyperparameters unvalidated (scikit-learn's rule); ``fit`` calls
:func:`check_hyperparameters`, which names the offending parameter, its value and what is
allowed, then :func:`build_model` turns the spec (``ansatz``, ``decomposition``, ``depth``,
``mixture``, ``readout``) or a :class:`DensityQNN` template into a fresh model.
"""

from __future__ import annotations

import copy
import math
import numbers

import numpy as np

from qdensity.circuits.ansatze.hamming import butterfly, pyramid, round_robin, x_circuit
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.learning.optim import SGD, Adam, RMSprop
from qdensity.models.decompositions import by_moments, cyclic_moments, odd_even
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import GatedMixture, SoftmaxMixture
from qdensity.validation import check_layers, check_num_qubits, check_seed

ANSATZE = {"round_robin": round_robin, "pyramid": pyramid, "x": x_circuit,
           "butterfly": butterfly}
DECOMPOSITIONS = ("layers", "cyclic", "odd_even", "none")
MIXTURES = ("softmax", "fixed", "moe", "moe_gelu")
READOUTS = ("unary_probabilities", "unary_amplitudes", "observable")
OPTIMIZERS = {"adam": Adam, "sgd": SGD, "rmsprop": RMSprop}
GRADIENTS = ("auto", "shift", "commuting")


def _choice(value, name: str, allowed) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(f"{name} must be one of {sorted(allowed)}, got {value!r}")


def _real(value, name: str, *, positive: bool = False, allow_none: bool = False) -> None:
    if value is None and allow_none:
        return
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or (v <= 0 if positive else v < 0):
        need = "> 0" if positive else ">= 0"
        raise ValueError(f"{name} must be finite and {need}, got {value!r}")


def _int(value, name: str, *, minimum: int = 1, allow_none: bool = False, why: str = "") -> None:
    if value is None and allow_none:
        return
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}{' (' + why + ')' if why else ''}"
                         f", got {value!r}")


def check_hyperparameters(est) -> None:
    """Validate every hyperparameter of a QNN estimator (called at the start of ``fit``)."""
    if est.model is not None and not isinstance(est.model, DensityQNN):
        raise TypeError(f"model must be a DensityQNN template or None, got "
                        f"{type(est.model).__name__}")
    if est.model is None:
        _choice(est.ansatz, "ansatz", ANSATZE)
        _choice(est.decomposition, "decomposition", DECOMPOSITIONS)
        _choice(est.mixture, "mixture", MIXTURES)
        _choice(est.readout, "readout", READOUTS)
        check_layers(est.depth, "depth")
        if est.num_qubits is not None:
            check_num_qubits(est.num_qubits, minimum=2)
        if est.constant is not None:
            _real(est.constant, "constant", positive=True)
        if not isinstance(est.scale, (bool, np.bool_)):
            raise TypeError(f"scale must be a bool (standardise the features before PCA and "
                            f"the encoding), got {est.scale!r}")
    _choice(est.optimizer, "optimizer", OPTIMIZERS)
    _real(est.learning_rate, "learning_rate", positive=True)
    _real(est.l2, "l2")
    _int(est.epochs, "epochs")
    _int(est.batch_size, "batch_size")
    _int(est.max_steps, "max_steps", allow_none=True)
    _int(est.max_shots, "max_shots", allow_none=True)
    _choice(est.gradient, "gradient", GRADIENTS)
    if isinstance(est.engine, SamplerEngine):
        if est.shots is None:
            raise ValueError("shots must be given (shots per circuit) with a SamplerEngine engine")
        _int(est.shots, "shots", minimum=2,
             why="a sampled gradient estimates each circuit's variance from its shots")
    elif isinstance(est.engine, str):
        if est.engine != "exact":
            raise ValueError(f"engine must be 'exact' or a SamplerEngine, got {est.engine!r}")
    else:
        raise TypeError(f"engine must be 'exact' or a SamplerEngine, got "
                        f"{type(est.engine).__name__} {est.engine!r}")
    if not isinstance(est.verbose, (bool, np.bool_)):
        raise TypeError(f"verbose must be a bool, got {est.verbose!r}")
    check_seed(est.seed)
    if est.callback is not None and not callable(est.callback):
        raise TypeError(f"callback must be callable (estimator, step), got {est.callback!r}")
    cbs = est.callbacks if est.callbacks is not None else ()
    if (isinstance(cbs, (str, bytes)) or not hasattr(cbs, "__iter__")
            or not all(callable(c) for c in cbs)):
        raise TypeError(f"callbacks must be a list of callables (estimator, record), got {cbs!r}")
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
    circuit = ANSATZE[est.ansatz](num_qubits)
    if est.decomposition == "none":
        subs = [circuit]
    elif est.decomposition == "layers":
        subs = by_moments(circuit, min(est.depth, _num_moments(circuit))).sub_unitaries
    elif est.decomposition == "cyclic":
        subs = cyclic_moments(circuit, min(est.depth, _num_moments(circuit))).sub_unitaries
    else:
        subs = odd_even(circuit).sub_unitaries
    K = len(subs)
    mixture: SoftmaxMixture | GatedMixture | None
    if est.mixture == "fixed":
        mixture = None
    elif est.mixture == "softmax":
        mixture = SoftmaxMixture(K)
    else:
        mixture = GatedMixture(num_qubits, K, activation="gelu" if est.mixture == "moe_gelu"
                               else None, seed=rng)
    return DensityQNN(subs, mixture, encoding=Encoding.unary(num_qubits), readout=est.readout,
                      seed=rng)


def _num_moments(circuit) -> int:
    from qdensity.analysis.structure import moments

    return max(len(moments(circuit)), 1)


def make_optimizer(est):
    """The optimiser named by ``optimizer`` with ``learning_rate`` (SGD with momentum 0.9)."""
    if est.optimizer == "sgd":
        return SGD(lr=est.learning_rate, momentum=0.9)
    return OPTIMIZERS[est.optimizer](lr=est.learning_rate)
