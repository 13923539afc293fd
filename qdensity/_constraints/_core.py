"""Declared argument constraints, the core (base, numbers, options, unions).

A public callable states what each argument accepts in one place, with ``validates``
(:mod:`qdensity._constraints._decorator`)::

    @validates(num_qubits=Qubits(minimum=2), layers=Interval(int, 1, MAX_LAYERS), seed=Seed())
    def pyramid(num_qubits, layers=1, seed=None): ...

The decorator binds each call's arguments (``inspect.signature(fn).bind``) and checks every
declared argument before the body runs; a violation is a ``TypeError`` (wrong type) or
``ValueError`` (right type, value not allowed) naming the callable, the argument, the value
(its ``repr``, truncated) and what is allowed. The declarations are stored on the function as
``fn.__constraints__`` (on a class, wrapped around ``__init__`` and kept as
``cls.__constraints__``) so that tests and the fuzzer read them: every constraint can say whether
a value satisfies it (``is_satisfied_by``), describe itself (``str``), give one valid example
(``example``) and a list of values that violate it (``violations``).

A declaration is a constraint, a list of them (any one may hold; ``None`` in the list allows
None) or a type (``isinstance``). The checks look at types, shapes, dtypes and one
``isfinite`` pass: no copies of numpy arrays, microseconds per call. Cross-argument checks stay
in the bodies (:func:`refuse` words their messages the same way).
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Callable, Iterable

import numpy as np

from qdensity._constraints._values import _python_scalar, _ScalarMixin

_NOT_A_FILE = os.path.join(os.sep, "nonexistent-qdensity-dir", "missing.file")


class Constraint:
    """What one argument accepts.

    Subclasses define ``type_ok`` (the value has an acceptable type; a failure is a
    ``TypeError``), ``is_satisfied_by`` (type and value acceptable), ``__str__`` (what is
    allowed, in words), ``example`` (one valid value) and ``violations`` (values that are not).

    Examples
    --------
    A new kind of argument subclasses it (the other methods have defaults):

    >>> from qdensity.validation import Constraint, validates
    >>> class Even(Constraint):
    ...     def is_satisfied_by(self, value): return isinstance(value, int) and value % 2 == 0
    ...     def __str__(self): return "an even int"
    >>> @validates(n=Even())
    ... def half(n): return n // 2
    >>> half(4), Even().is_satisfied_by(3)
    (2, False)
    """

    def type_ok(self, value) -> bool:
        return self.is_satisfied_by(value)

    def is_satisfied_by(self, value) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def reason(self, value) -> str:
        """Why ``value`` fails (empty when ``str(self)`` says it all)."""
        return ""

    def normalise(self, value):
        """The value the body receives for an accepted ``value`` (a numpy scalar of a scalar
        declaration becomes the Python number it means; everything else as given)."""
        return value

    def accept(self, value) -> tuple[bool, object]:
        """``(True, normalise(value))`` for an accepted ``value``, else ``(False, value)``: one
        check where :meth:`is_satisfied_by` then :meth:`normalise` would check twice."""
        if self.is_satisfied_by(value):
            return True, self.normalise(value)
        return False, value

    def example(self) -> object:  # pragma: no cover - abstract
        raise NotImplementedError

    def violations(self) -> list:
        """Values that violate this constraint (the fuzzer draws from them)."""
        return [object(), "bogus", None, math.nan, -1, 1e300, 1j, []]


class Unchecked(Constraint):
    """An argument no single constraint describes (``**kwargs`` passed on, a value whose checks
    need other arguments); ``why`` says where it is checked. The fuzzer skips it.

    Examples
    --------
    >>> from qdensity.validation import Unchecked
    >>> c = Unchecked("passed on to qiskit's transpile")
    >>> c.is_satisfied_by(object()), c.violations()
    (True, [])
    """

    def __init__(self, why: str, example=None):
        self.why, self._example = why, example

    def is_satisfied_by(self, value) -> bool:
        return True

    def __str__(self) -> str:
        return f"anything here ({self.why})"

    def example(self) -> object:
        return self._example

    def violations(self) -> list:
        return []


class Instance(_ScalarMixin, Constraint):
    """``isinstance(value, types)``; ``what`` names the types in words (bools refused as ints).

    Examples
    --------
    >>> from qdensity.validation import Instance
    >>> c = Instance((int, float), "a number")
    >>> c.is_satisfied_by(2.5), c.is_satisfied_by(True), str(c)  # bools are not numbers here
    (True, False, 'a number')
    """

    def __init__(self, types, what: str | None = None, example=None):
        self._types = types if isinstance(types, tuple) else (types,)
        self.what = what or " or ".join(t.rsplit(":", 1)[-1] if isinstance(t, str) else
                                        t.__name__ for t in self._types)
        self._example = example
        self._lazy = any(isinstance(t, str) for t in self._types)

    @property
    def types(self) -> tuple:
        """The classes; ``"module:Class"`` strings (a class of a higher layer) load on first
        use."""
        if self._lazy and any(isinstance(t, str) for t in self._types):
            import importlib

            self._types = tuple(getattr(importlib.import_module(t.split(":")[0]),
                                        t.split(":")[1]) if isinstance(t, str) else t
                                for t in self._types)
            self._lazy = False
        return self._types

    def is_satisfied_by(self, value) -> bool:
        if isinstance(value, np.generic) and not isinstance(value, self.types):
            value = value.item()  # np.int64(3) is an int, np.bool_(True) a bool
        if isinstance(value, (bool, np.bool_)) and bool not in self.types:
            return False
        return isinstance(value, self.types)

    def type_ok(self, value) -> bool:
        return Instance.is_satisfied_by(self, value)

    def __str__(self) -> str:
        if self.what.startswith(("a ", "an ")):
            return self.what
        return f"{'an' if self.what[:1].lower() in 'aeiou' else 'a'} {self.what}"

    def example(self) -> object:
        if self._example is not None:
            return self._example() if callable(self._example) else self._example
        for t in self.types:  # builtins only: constructing other classes has side effects
            if t in (str, int, float, list, tuple, dict, bool):
                return t()
        raise LookupError(f"no example for {self}")

    def violations(self) -> list:
        return [v for v in [object(), "bogus", 1.5, -1, math.nan, 1j, [], b"x"]
                if not self.is_satisfied_by(v)]


class Interval(_ScalarMixin, Constraint):
    """A real or integer number in an interval (bools refused, reals finite).

    Parameters
    ----------
    kind : int or float
        ``int`` (any ``numbers.Integral``) or ``float`` (any finite ``numbers.Real``).
    low, high : number or None
        Bounds; None is unbounded on that side (a ``high`` is an upper bound on what the
        library will allocate or run: qubits, shots, rows, counts).
    closed : {"both", "left", "right", "neither"}
    why : str
        Why the bound is there (for the message).

    Examples
    --------
    >>> from qdensity.validation import Interval
    >>> c = Interval(float, 0, 1, closed="left")
    >>> c.is_satisfied_by(0.0), c.is_satisfied_by(1.0), str(c)
    (True, False, 'a finite real number >= 0 and < 1')
    """

    def __init__(self, kind, low=None, high=None, *, closed: str = "both", why: str = ""):
        if kind not in (int, float):
            raise TypeError(f"kind must be int or float, got {kind!r}")
        if closed not in ("both", "left", "right", "neither"):
            raise ValueError(f"closed must be 'both', 'left', 'right' or 'neither', got {closed!r}")
        self.kind, self.low, self.high, self.closed, self.why = kind, low, high, closed, why

    def type_ok(self, value) -> bool:
        if isinstance(value, (bool, np.bool_)):
            return False
        return isinstance(value, numbers.Integral if self.kind is int else numbers.Real)

    def normalise(self, value):
        value = _python_scalar(value)
        return float(value) if self.kind is float and not isinstance(value, int) else value

    def is_satisfied_by(self, value) -> bool:
        if not self.type_ok(value):
            return False
        if self.kind is float and not math.isfinite(value):
            return False
        lo_ok = self.low is None or (value >= self.low if self.closed in ("both", "left")
                                     else value > self.low)
        hi_ok = self.high is None or (value <= self.high if self.closed in ("both", "right")
                                      else value < self.high)
        return bool(lo_ok and hi_ok)

    def __str__(self) -> str:
        noun = "an int" if self.kind is int else "a finite real number"
        ge = ">=" if self.closed in ("both", "left") else ">"
        le = "<=" if self.closed in ("both", "right") else "<"
        bounds = ([f"{ge} {self.low!r}"] if self.low is not None else []) + (
            [f"{le} {self.high!r}"] if self.high is not None else [])
        out = " ".join([noun, " and ".join(bounds)]).strip()
        return out + (f" ({self.why})" if self.why else "")

    def example(self) -> int | float:
        if self.kind is int:
            lo = self.low if self.low is not None else 0
            lo = lo if self.closed in ("both", "left") else lo + 1
            return int(math.ceil(lo)) if self.high is None or lo <= self.high else int(self.high)
        if self.low is not None and self.high is not None:
            return (self.low + self.high) / 2
        if self.low is not None:
            return float(self.low) + 1.0
        return float(self.high) - 1.0 if self.high is not None else 0.5

    def violations(self) -> list:
        out = ["1", None, 1j, True, [1], math.nan, math.inf, -math.inf]
        if self.kind is int:
            out.append(2.5)
        if self.low is not None:
            out += [self.low - 1, self.low - 1e-3 if self.kind is float else self.low - 1]
            if self.closed in ("right", "neither"):
                out.append(self.low)
            out.append(-10**12)
        if self.high is not None:
            out += [self.high + 1, 10**12 if self.kind is int else 1e300]
            if self.closed in ("left", "neither"):
                out.append(self.high)
        return [v for v in out if not self.is_satisfied_by(v)]


class Options(_ScalarMixin, Constraint):
    """One of a fixed set of values (strings, usually); given as a callable returning them,
    the set is read at each check (a registry that grows after the declaration).

    Examples
    --------
    >>> from qdensity.validation import Options
    >>> c = Options(["softmax", "fixed"])
    >>> c.is_satisfied_by("fixed"), c.is_satisfied_by("bogus"), c.options
    (True, False, ('softmax', 'fixed'))
    """

    def __init__(self, options: Iterable | Callable[[], Iterable]):
        self._source = options if callable(options) else tuple(options)

    @property
    def options(self) -> tuple:
        """The allowed values, now."""
        source = self._source
        return tuple(source()) if callable(source) else source

    def type_ok(self, value) -> bool:
        value = _python_scalar(value)  # np.str_("a") is "a", np.int64(2) is 2
        return any(type(value) is type(o) for o in self.options)

    def is_satisfied_by(self, value) -> bool:
        try:
            return self.type_ok(value) and _python_scalar(value) in self.options
        except TypeError:  # unhashable or incomparable
            return False

    def __str__(self) -> str:
        if len(self.options) == 1:
            return repr(self.options[0])
        return "one of " + ", ".join(repr(o) for o in self.options)

    def example(self) -> object:
        return self.options[0]

    def violations(self) -> list:
        return [v for v in ["bogus", "", 3, None, object(), math.nan, ["x"]]
                if not self.is_satisfied_by(v)]


class _AnyOf(Constraint):
    """Any one of several constraints (a declared list)."""

    def __init__(self, members):
        self.members = [as_constraint(m) for m in members]

    def type_ok(self, value) -> bool:
        return any(m.type_ok(value) for m in self.members)

    def is_satisfied_by(self, value) -> bool:
        return any(m.is_satisfied_by(value) for m in self.members)

    def reason(self, value) -> str:
        for m in self.members:
            if m.type_ok(value):
                return m.reason(value)
        return ""

    def normalise(self, value):
        return self.accept(value)[1]

    def accept(self, value) -> tuple[bool, object]:
        for m in self.members:
            ok, out = m.accept(value)
            if ok:
                return True, out
        return False, value

    def __str__(self) -> str:
        return " or ".join(str(m) for m in self.members)

    def example(self):
        for m in self.members:
            try:
                return m.example()
            except LookupError:
                continue
        raise LookupError(f"no example for {self}")

    def violations(self) -> list:
        out = [v for m in self.members for v in m.violations()]
        return [v for v in out if not self.is_satisfied_by(v)]


class _IsNone(Constraint):
    def is_satisfied_by(self, value) -> bool:
        return value is None

    def __str__(self) -> str:
        return "None"

    def example(self):
        return None

    def violations(self) -> list:
        return [0]


def as_constraint(declaration) -> Constraint:
    """A :class:`Constraint` from a declaration: a constraint, a type, None or a list of them.

    Examples
    --------
    A list means "any one of these"; None in it allows None:

    >>> from qdensity.validation import as_constraint
    >>> c = as_constraint([int, None])
    >>> c.is_satisfied_by(3), c.is_satisfied_by(None), c.is_satisfied_by("3")
    (True, True, False)
    """
    if isinstance(declaration, Constraint):
        return declaration
    if declaration is None:
        return _IsNone()
    if isinstance(declaration, type):
        return Instance(declaration)
    if isinstance(declaration, tuple) and all(isinstance(t, type) for t in declaration):
        return Instance(declaration)
    if isinstance(declaration, list):
        return _AnyOf(declaration) if len(declaration) > 1 else as_constraint(declaration[0])
    raise TypeError(f"a declaration must be a Constraint, a type, None or a list of them, got "
                    f"{declaration!r}")


#: Widest circuit a builder makes (far beyond any device; refuses 10**9 before building).
MAX_CIRCUIT_QUBITS = 4096
#: Most repetitions (layers, reps) a builder makes.
MAX_LAYERS = 10_000
#: Most shots one call may ask for (10**8 shots is hours of sampling).
MAX_SHOTS = 10**8
#: Most shots one plan may spend in total, over all its jobs and rows (days of sampling).
MAX_PLAN_SHOTS = 10**10
#: Most data rows, parameter rows or units one call may ask for.
MAX_ROWS = 10**7
#: Most sub-unitaries (K) a density model or preparation circuit may hold.
MAX_SUBUNITARIES = 10_000
#: Most seeds (repetitions) one experiment run may ask for.
MAX_SEEDS = 10_000


def Qubits(minimum: int = 1, maximum: int = MAX_CIRCUIT_QUBITS) -> Interval:
    """The declared width of a circuit: an int in ``[minimum, maximum]``.

    Examples
    --------
    >>> from qdensity.validation import Qubits
    >>> [Qubits(2).is_satisfied_by(n) for n in (1, 2, 4096, 4097)]  # at most MAX_CIRCUIT_QUBITS
    [False, True, True, False]
    """
    return Interval(int, minimum, maximum, why="wider circuits are beyond any device and take "
                    "minutes to build" if maximum == MAX_CIRCUIT_QUBITS else "")


def Layers(minimum: int = 1) -> Interval:
    """The declared repetition count of a builder: an int in ``[minimum, MAX_LAYERS]``.

    Examples
    --------
    >>> from qdensity.validation import Layers
    >>> Layers().is_satisfied_by(3), Layers().is_satisfied_by(0), Layers(0).is_satisfied_by(0)
    (True, False, True)
    """
    return Interval(int, minimum, MAX_LAYERS, why="deeper circuits take minutes to build")


def Shots(minimum: int = 1) -> Interval:
    """The declared shot count: an int in ``[minimum, MAX_SHOTS]``.

    Examples
    --------
    >>> from qdensity.validation import MAX_SHOTS, Shots
    >>> Shots().is_satisfied_by(1000), Shots().is_satisfied_by(MAX_SHOTS + 1)
    (True, False)
    """
    return Interval(int, minimum, MAX_SHOTS)
