"""Declared argument constraints: the vocabulary that :mod:`qdensity.validation` exports.

The core (:mod:`._core`: the base class, numbers, options, unions), the :func:`validates`
decorator and its refusals (:mod:`._decorator`), and the kinds of values the library takes
(:mod:`._kinds`: arrays, paths, circuits, observables, engines, targets; :mod:`._seeds`: seeds;
:mod:`._checks`: callables, sequences, torch tensors).
"""

from qdensity._constraints._checks import CallableC, SequenceOf, TorchTensor
from qdensity._constraints._core import (
    MAX_CIRCUIT_QUBITS,
    MAX_LAYERS,
    MAX_PLAN_SHOTS,
    MAX_ROWS,
    MAX_SEEDS,
    MAX_SHOTS,
    MAX_SUBUNITARIES,
    Constraint,
    Instance,
    Interval,
    Layers,
    Options,
    Qubits,
    Shots,
    Unchecked,
    as_constraint,
)
from qdensity._constraints._decorator import check_declared, declared, refuse, validates
from qdensity._constraints._kinds import (
    Array,
    Circuit,
    EngineLike,
    FileName,
    FilePath,
    Observable,
    TargetLike,
)
from qdensity._constraints._seeds import Seed

__all__ = ["Constraint", "Instance", "Interval", "Options", "Array", "FilePath", "FileName",
           "Circuit", "Observable", "EngineLike", "TargetLike", "Seed", "CallableC", "SequenceOf",
           "Unchecked", "TorchTensor", "validates", "refuse", "as_constraint", "declared",
           "check_declared", "MAX_CIRCUIT_QUBITS",
           "MAX_LAYERS", "MAX_SHOTS", "MAX_PLAN_SHOTS", "MAX_ROWS", "MAX_SEEDS",
           "MAX_SUBUNITARIES", "Qubits",
           "Layers", "Shots"]
