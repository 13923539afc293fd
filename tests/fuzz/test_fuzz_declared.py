"""The fuzzer generated from the declarations (issue "One contract for the public surface",
item 2): no case list.

For every public callable (``_api.py``) and every argument it declares, hypothesis draws a
value outside the declaration (each constraint lists values that violate it: wrong type, NaN,
+-inf, negative, zero, huge, empty, wrong shape or dtype, complex, a path that is not a file;
intervals add drawn numbers beyond their bounds) while every other declared argument gets the
declaration's own valid example. The call must raise ``ValueError`` or ``TypeError`` whose
message names the argument, within 5 s and with a tracemalloc peak under 256 MB.

Each bad value is checked against the declaration first (it must violate it), so the oracle is
the declaration, not the code under test. Estimators (scikit-learn's convention: hyperparameters
checked by ``fit``) are constructed with the bad value and fitted on four rows.

``QDENSITY_FUZZ_EXAMPLES`` sets the examples per argument (3 in CI);
``benchmarks/fuzz_api.py --examples N`` runs it long.
"""

from __future__ import annotations

import inspect
import math
import os
import time
import tracemalloc

import numpy as np
import pytest
from _api import declarations, is_estimator, parameters, public_callables
from _fuzz import TALLY
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from qdensity.validation import Interval, Unchecked

EXAMPLES = int(os.environ.get("QDENSITY_FUZZ_EXAMPLES", "3"))
SECONDS = 5.0
PEAK_BYTES = 256 * 2**20

PUBLIC = public_callables()
CASES = [(name, arg) for name, obj in PUBLIC.items()
         for arg, c in declarations(obj).items() if not isinstance(c, Unchecked)]


def _outside(c: Interval):
    """Numbers beyond an interval's bounds, drawn (beside its listed violations)."""
    parts = []
    if c.kind is int:
        if c.low is not None:
            parts.append(st.integers(max_value=math.ceil(c.low) - 1))
        if c.high is not None:
            parts.append(st.integers(min_value=math.floor(c.high) + 1))
    else:
        if c.low is not None:
            parts.append(st.floats(max_value=c.low, exclude_max=True, allow_nan=False,
                                   allow_infinity=False))
        if c.high is not None:
            parts.append(st.floats(min_value=c.high, exclude_min=True, allow_nan=False,
                                   allow_infinity=False))
    return parts


def violating(c):
    """A strategy of values that violate declaration ``c``."""
    parts = [st.sampled_from(c.violations())]
    members = getattr(c, "members", [c])
    for m in members:
        if isinstance(m, Interval):
            parts += _outside(m)
    return st.one_of(parts).filter(lambda v: not c.is_satisfied_by(v))


def _made(cls):
    """A valid value of a class the declarations name but give no example of."""
    from qiskit.circuit import QuantumCircuit
    from qiskit.quantum_info import SparsePauliOp, Statevector

    from qdensity.circuits.ansatze.hamming import pyramid

    table = {
        "SparsePauliOp": lambda: SparsePauliOp("ZZ"),
        "Statevector": lambda: Statevector.from_label("00"),
        "CircuitInstruction": lambda: pyramid(2).data[0],
        "DensityQNN": lambda: PUBLIC["qdensity.models.density.DensityQNN"]([pyramid(2)]),
        "QuantumCircuit": lambda: QuantumCircuit(2),
        "Mapping": dict,
    }
    for klass in cls.__mro__:
        if klass.__name__ in table:
            return table[klass.__name__]()
    # an object only the library makes (a result, a client): an instance the declaration
    # accepts; the body never runs, since the fuzzed argument is refused first
    return object.__new__(cls) if cls.__new__ is object.__new__ else cls.__new__(cls)


def _example(c):
    """A value that satisfies declaration ``c``."""
    try:
        return c.example()
    except LookupError:
        pass
    for m in getattr(c, "members", [c]):
        if hasattr(m, "item"):  # a sequence: of valid items
            return [_example(m.item)] * max(m.min_len, 1)
        for t in getattr(m, "types", ()):
            try:
                value = _made(t)
            except TypeError:  # abstract: try the next type
                continue
            if c.is_satisfied_by(value):
                return value
    raise LookupError(f"no valid example for {c}")


def _call(obj, kwargs):
    params = parameters(obj)
    args = [kwargs.pop(k) for k, p in params.items() if p.kind == p.POSITIONAL_ONLY]
    if is_estimator(obj):
        est = obj(**kwargs)
        X = np.array([[0.1, 0.2], [0.3, 0.1], [0.2, 0.4], [0.4, 0.3]])
        y = np.array([0, 1, 0, 1])
        return est.fit(X, y)
    return obj(*args, **kwargs)


@pytest.mark.parametrize(("name", "arg"), CASES, ids=[f"{n}:{a}" for n, a in CASES])
@settings(max_examples=EXAMPLES, suppress_health_check=list(HealthCheck), deadline=None)
@given(data=st.data())
def test_a_value_outside_the_declaration_is_refused_naming_the_argument(name, arg, data):
    obj = PUBLIC[name]
    decl = declarations(obj)
    params = parameters(obj)
    kwargs = {}
    for k, p in params.items():
        if k != arg and p.default is p.empty:  # optional ones keep their (declared) defaults
            kwargs[k] = _example(decl[k]) if k in decl else None
    bad = data.draw(violating(decl[arg]), label=arg)
    kwargs[arg] = bad
    TALLY[name] += 1
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        _call(obj, dict(kwargs))
    except (ValueError, TypeError) as exc:
        elapsed = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert arg in str(exc), f"{name}({arg}={bad!r}) refused without naming {arg}: {exc}"
        assert elapsed < SECONDS, f"{name}({arg}={bad!r}) took {elapsed:.1f} s to refuse"
        assert peak < PEAK_BYTES, f"{name}({arg}={bad!r}) allocated {peak / 2**20:.0f} MB"
        return
    except BaseException as exc:  # noqa: BLE001 - any other outcome is the failure reported
        tracemalloc.stop()
        raise AssertionError(f"{name}({arg}={bad!r}) raised {type(exc).__name__}: {exc}") from exc
    tracemalloc.stop()
    raise AssertionError(f"{name} accepted {arg}={bad!r}, outside its declaration "
                         f"{decl[arg]}")


def test_every_callable_with_declarations_is_fuzzed():
    fuzzed = {n for n, _ in CASES}
    declared_any = {n for n, obj in PUBLIC.items() if declarations(obj)
                    and not all(isinstance(c, Unchecked) for c in declarations(obj).values())}
    assert fuzzed == declared_any


def test_signatures_are_kept():
    # the decorator keeps each callable's signature (scikit-learn's get_params and help() read it)
    for obj in PUBLIC.values():
        if isinstance(obj, type) and issubclass(obj, Warning):
            continue  # a warning category: raised by the library, never called
        inspect.signature(obj)
