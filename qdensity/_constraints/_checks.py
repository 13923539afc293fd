"""Callables, sequences, engines, targets and torch tensors: the constraints that declare them
and the checks that bodies call. Exported by :mod:`qdensity.validation`.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable
from typing import NoReturn, TypeVar

import numpy as np

from qdensity._constraints._core import Constraint, as_constraint
from qdensity._constraints._values import _python_scalar, _show

__all__ = ["CallableC", "SequenceOf", "TorchTensor", "check_callable", "check_type",
           "check_sequence_of", "check_engine", "check_target"]

#: What a pass-through check returns: the value it was given, with its type.
_T = TypeVar("_T")
_C = TypeVar("_C", bound=Callable)


class CallableC(Constraint):
    """A callable (``what`` says which, in words).

    Examples
    --------
    >>> from qdensity.validation import CallableC
    >>> c = CallableC("a loss function")
    >>> c.is_satisfied_by(abs), c.is_satisfied_by("mse"), str(c)
    (True, False, 'a loss function')
    """

    def __init__(self, what: str = "a callable"):
        self.what = what

    def is_satisfied_by(self, value) -> bool:
        return callable(value)

    def __str__(self) -> str:
        return self.what

    def example(self) -> Callable[..., object]:
        return np.asarray

    def violations(self) -> list:
        return ["notcallable", 3, None, math.nan, []]


class SequenceOf(Constraint):
    """A list, tuple (or ``range``, ``ParameterVector``, 1-d numpy array, handed to the body as
    a list of Python values) of ``min_len`` to ``max_len`` items, each satisfying ``item``.

    Examples
    --------
    >>> from qdensity.validation import Interval, SequenceOf
    >>> c = SequenceOf(Interval(int, 0), min_len=2, max_len=2)
    >>> c.is_satisfied_by((0, 3)), c.is_satisfied_by([0]), c.is_satisfied_by([0, -1])
    (True, False, False)
    """

    def __init__(self, item, *, min_len: int = 1, max_len: int | None = None):
        self.item, self.min_len, self.max_len = as_constraint(item), min_len, max_len

    def type_ok(self, value) -> bool:
        from qiskit.circuit import ParameterVector

        if isinstance(value, np.ndarray):  # a 1-d array means the list of its items
            if value.ndim != 1 or value.dtype.kind == "c":
                return False
        elif not isinstance(value, (list, tuple, range, ParameterVector)):
            return False
        return all(self.item.type_ok(v) for v in value)

    def is_satisfied_by(self, value) -> bool:
        if not self.type_ok(value) or len(value) < self.min_len:
            return False
        if self.max_len is not None and len(value) > self.max_len:
            return False
        return all(self.item.is_satisfied_by(v) for v in value)

    def normalise(self, value):
        if isinstance(value, np.ndarray):  # the body gets the list of Python values
            return [self.item.normalise(_python_scalar(v)) for v in value]
        if type(value) in (list, tuple) and any(isinstance(v, np.generic) for v in value):
            return type(value)(self.item.normalise(_python_scalar(v)) for v in value)
        return value

    def reason(self, value) -> str:
        if self.type_ok(value):
            if len(value) < self.min_len or (self.max_len is not None
                                             and len(value) > self.max_len):
                return f"it has {len(value)} items"
            for i, v in enumerate(value):
                if not self.item.is_satisfied_by(v):
                    why = self.item.reason(v)
                    return f"[{i}] is {_show(v)}" + (f": {why}" if why else "")
        elif isinstance(value, (list, tuple)):
            for i, v in enumerate(value):
                if not self.item.type_ok(v):
                    return f"[{i}] is {_show(v)}"
        return ""

    def __str__(self) -> str:
        bound = f"{self.min_len}" + (f" to {self.max_len}" if self.max_len is not None
                                     else " or more")
        return f"a list or tuple of {bound} items, each {self.item}"

    def example(self) -> list:
        if self.min_len == 0:
            return []
        return [self.item.example()] * self.min_len

    def violations(self) -> list:
        out = ["bogus", 3, None, object()]
        if self.min_len:
            out.append([])
        bad = [v for v in self.item.violations() if v is not None][:2]
        out += [[b] * max(self.min_len, 1) for b in bad]
        return [v for v in out if not self.is_satisfied_by(v)]


class TorchTensor(Constraint):
    """A ``torch.Tensor`` of ``ndim`` dimensions (the torch engines' inputs), checked without
    importing torch: a tensor can only exist once torch is imported. Its values are checked
    by the torch engine on the tensor's own device (no copy to the host here).

    Examples
    --------
    Checked without importing torch (a tensor exists only once torch is imported):

    >>> import numpy as np
    >>> from qdensity.validation import TorchTensor
    >>> TorchTensor(2).is_satisfied_by(np.zeros((2, 2))), str(TorchTensor((1, 2)))
    (False, 'a 1 or 2-dimensional torch.Tensor')
    """

    def __init__(self, ndim: int | tuple[int, ...]):
        self.ndim = (ndim,) if isinstance(ndim, int) else tuple(ndim)

    def type_ok(self, value) -> bool:
        torch = sys.modules.get("torch")
        return torch is not None and isinstance(value, torch.Tensor)

    def is_satisfied_by(self, value) -> bool:
        return self.type_ok(value) and value.dim() in self.ndim

    def __str__(self) -> str:
        dims = " or ".join(str(d) for d in self.ndim)
        return f"a {dims}-dimensional torch.Tensor"

    def example(self) -> NoReturn:
        raise LookupError("no example for a torch tensor (torch is optional)")

    def violations(self) -> list:
        return [object(), "bogus", None, 1j]


def check_callable(value: _C, name: str, what: str = "a callable") -> _C:
    """``value`` if it is callable, else a ``TypeError`` naming ``name`` and ``what``.

    Examples
    --------
    >>> check_callable(len, "fn") is len
    True
    >>> check_callable(3, "fn", "a loss function")
    Traceback (most recent call last):
        ...
    TypeError: fn must be a loss function, got int 3
    """
    if not callable(value):
        raise TypeError(f"{name} must be {what}, got {type(value).__name__} {value!r}")
    return value


def check_type(value: _T, name: str, types, expected: str, *, allow_none: bool = False) -> _T:
    """``value`` if it is an instance of ``types`` (or None with ``allow_none``), else a
    ``TypeError`` naming ``name``, what is ``expected`` in words, and what came.

    Examples
    --------
    >>> check_type(None, "ledger", dict, "a dict", allow_none=True) is None
    True
    >>> check_type([], "ledger", dict, "a dict")
    Traceback (most recent call last):
        ...
    TypeError: ledger must be a dict, got list []
    """
    if value is None and allow_none:
        return value
    if not isinstance(value, types):
        extra = " or None" if allow_none else ""
        raise TypeError(f"{name} must be {expected}{extra}, got {type(value).__name__} "
                        f"{value!r:.80}")
    return value


def check_sequence_of(values, name: str, types, expected: str) -> list:
    """``values`` as a list whose every item is an instance of ``types`` (``TypeError`` naming
    ``name`` or ``name[i]`` otherwise; a lone item, a string or a non-iterable is refused).

    Examples
    --------
    >>> check_sequence_of((1, 2), "sizes", int, "int")
    [1, 2]
    >>> check_sequence_of([1, "2"], "sizes", int, "int")
    Traceback (most recent call last):
        ...
    TypeError: sizes[1] must be a int, got str '2'
    """
    if isinstance(values, (str, bytes, types)) or not hasattr(values, "__iter__"):
        raise TypeError(f"{name} must be a sequence of {expected}, got "
                        f"{type(values).__name__} {values!r:.80}")
    out = list(values)
    for i, v in enumerate(out):
        if not isinstance(v, types):
            raise TypeError(f"{name}[{i}] must be a {expected}, got {type(v).__name__} "
                            f"{v!r:.80}")
    return out


def check_engine(engine: _T, name: str = "engine") -> _T:
    """An engine (anything with ``run(jobs)``: ExactEngine, SamplerEngine, AdjointEngine).

    Examples
    --------
    >>> from qdensity.execution import ExactEngine
    >>> engine = ExactEngine()
    >>> check_engine(engine) is engine
    True
    >>> check_engine("exact")
    Traceback (most recent call last):
        ...
    TypeError: engine must be an engine with run(jobs) ...
    """
    if not callable(getattr(engine, "run", None)):
        raise TypeError(f"{name} must be an engine with run(jobs) (ExactEngine, SamplerEngine, "
                        f"AdjointEngine), got {type(engine).__name__} {engine!r:.80}")
    return engine


def check_target(target: _T, name: str = "target") -> _T:
    """Anything a target may be given as, or None: a ``HardwareTarget``, a target name or
    snapshot path, a ``BackendV2`` or a ``qiskit.transpiler.Target`` (``as_target`` in
    ``qdensity.hardware.targets`` builds each; this only refuses the wrong types, by name).

    Examples
    --------
    >>> check_target("heavy_hex"), check_target(None)
    ('heavy_hex', None)
    >>> check_target(3)
    Traceback (most recent call last):
        ...
    TypeError: target must be a HardwareTarget, a target name or snapshot path, ...
    """
    if target is None or isinstance(target, (str, os.PathLike)):
        return target
    if all(callable(getattr(target, a, None)) for a in ("simulator", "transpile")):
        return target
    from qiskit.providers import BackendV2
    from qiskit.transpiler import Target

    if isinstance(target, (BackendV2, Target)):
        return target
    raise TypeError(f"{name} must be a HardwareTarget, a target name or snapshot path, a "
                    f"BackendV2 or a qiskit.transpiler.Target "
                    f"(qdensity.hardware.targets.get_target), "
                    f"or None; got {type(target).__name__} {target!r:.80}")
