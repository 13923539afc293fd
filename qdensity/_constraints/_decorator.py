"""The :func:`validates` decorator, and the refusals it and the bodies raise.

See :mod:`qdensity._constraints._core` for what a declaration is. Exported by
:mod:`qdensity.validation`.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable

from qdensity._constraints._core import Constraint, Unchecked, as_constraint
from qdensity._constraints._values import _show

__all__ = ["validates", "refuse", "check_declared", "declared"]

def refuse(where: str, name: str, value, allowed, reason: str = "",
           error: type[Exception] = ValueError) -> Exception:
    """The error a declaration raises, for checks that stay in a body (cross-argument ones):
    ``"{where}: {name} must be {allowed}, got {value}"``; raise what it returns.

    Examples
    --------
    A cross-argument check in a body, worded as the declarations word theirs:

    >>> from qdensity.validation import refuse
    >>> raise refuse("split", "test_size", 5, "less than the 4 rows")
    Traceback (most recent call last):
        ...
    ValueError: split: test_size must be less than the 4 rows, got 5
    """
    if reason.startswith("["):  # an item of a sequence: name it as name[i]
        return error(f"{where}: {name} must be {allowed}; {name}{reason}")
    text = f"{where}: {name} must be {allowed}, got {_show(value)}"
    return error(text + (f" ({reason})" if reason else ""))


def _check(where: str, name: str, constraint: Constraint, value):
    """``value`` as the body receives it (:meth:`Constraint.normalise`), or the refusal."""
    ok, accepted = constraint.accept(value)
    if ok:
        return accepted
    error = ValueError if constraint.type_ok(value) else TypeError
    raise refuse(where, name, value, constraint, constraint.reason(value), error)


def check_declared(where: str, constraints: dict, arguments: dict) -> None:
    """Check ``arguments`` (name -> value) against ``constraints`` (name -> declaration) as
    :func:`validates` does; for hyperparameters checked when a scikit-learn estimator is fitted
    (its ``_parameter_constraints``) rather than when it is constructed.

    Examples
    --------
    >>> from qdensity.validation import Interval, check_declared
    >>> check_declared("Model.fit", {"lr": Interval(float, 0)}, {"lr": -1.0})
    Traceback (most recent call last):
        ...
    ValueError: Model.fit: lr must be a finite real number >= 0, got -1.0
    """
    for name, declaration in constraints.items():
        if name in arguments:
            _check(where, name, as_constraint(declaration), arguments[name])


def declared(fn) -> dict[str, Constraint]:
    """The declarations of a callable or class (``{}`` when it declares none).

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.validation import declared
    >>> "num_qubits" in declared(pyramid), declared(len)
    (True, {})
    """
    return dict(getattr(fn, "__constraints__", None) or {})


def validates(**declarations) -> Callable:
    """Declare what each argument of a function (or a class's constructor) accepts.

    Parameters
    ----------
    **declarations
        ``argument name -> declaration`` (a :class:`Constraint`, a type, None, or a list of
        them of which one must hold). Every name must be a parameter of the decorated callable.

    Returns
    -------
    callable
        A decorator. The decorated callable checks each declared argument it is given, before
        its body runs, and carries the declarations as ``__constraints__``.

    Examples
    --------
    >>> from qdensity.validation import Interval, Qubits, validates
    >>> @validates(num_qubits=Qubits(2), angle=Interval(float))
    ... def ring(num_qubits, angle=0.0): return num_qubits
    >>> ring(4)
    4
    >>> ring(1)
    Traceback (most recent call last):
        ...
    ValueError: ring: num_qubits must be an int >= 2 and <= 4096 (wider circuits ...), got 1
    """
    constraints = {k: as_constraint(v) for k, v in declarations.items()}

    def decorate(obj):
        # a class is checked at its constructor (the class's own, looked up on the class)
        target = obj.__dict__.get("__init__", obj.__init__) if isinstance(obj, type) else obj  # type: ignore[misc]
        sig = inspect.signature(target)
        unknown = set(constraints) - set(sig.parameters)
        if unknown:
            raise TypeError(f"validates: {obj.__qualname__} has no parameters {sorted(unknown)}")
        where = obj.__qualname__
        if isinstance(obj, type):
            where = obj.__qualname__
        items = [(k, constraints[k]) for k in sig.parameters if k in constraints]

        @functools.wraps(target)
        def checked(*args, **kwargs):
            try:
                bound = sig.bind(*args, **kwargs)
            except TypeError as exc:
                raise TypeError(f"{where}: {exc}") from None
            arguments, changed = bound.arguments, False
            for name, constraint in items:
                if name in arguments:
                    value = _check(where, name, constraint, arguments[name])
                    if value is not arguments[name]:  # a numpy scalar, as its Python value
                        arguments[name], changed = value, True
            if changed:
                args, kwargs = bound.args, bound.kwargs
            if not isinstance(obj, type):
                return target(*args, **kwargs)
            key = id(args[0])  # under construction: its own assignments are not re-checked
            _BUILDING[key] = _BUILDING.get(key, 0) + 1
            try:
                return target(*args, **kwargs)
            finally:
                if _BUILDING[key] == 1:
                    del _BUILDING[key]
                else:
                    _BUILDING[key] -= 1

        checked.__constraints__ = constraints  # type: ignore[attr-defined]  # our own marker
        if isinstance(obj, type):
            type.__setattr__(obj, "__init__", checked)
            type.__setattr__(obj, "__constraints__", constraints)
            _check_assignments(obj, where, constraints)
            return obj
        return checked

    return decorate


#: ``id`` of each instance whose checked constructor is running -> nesting depth.
_BUILDING: dict[int, int] = {}


def _check_assignments(cls: type, where: str, constraints: dict) -> None:
    """Check a public attribute that holds a constructor argument when it is assigned again
    (``model.readout = "bogus"`` is refused as ``DensityQNN(readout="bogus")`` is, instead of
    being read later or ignored). Assignments made while the constructor runs are its own
    (the checked argument, or what it was turned into); attributes behind a property check
    in their setters."""
    public = {k: c for k, c in constraints.items()
              if not k.startswith("_") and not isinstance(c, Unchecked)}
    if not public:
        return
    inherited: Callable[..., None] = cls.__setattr__

    def __setattr__(self, name, value):
        constraint = public.get(name)
        if (constraint is not None and id(self) not in _BUILDING
                and name in getattr(self, "__dict__", ())):
            value = _check(f"{where}.{name}", name, constraint, value)
        inherited(self, name, value)

    __setattr__.__qualname__ = f"{cls.__qualname__}.__setattr__"
    type.__setattr__(cls, "__setattr__", __setattr__)
