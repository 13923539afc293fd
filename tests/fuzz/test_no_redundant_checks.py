"""A declared argument is checked once, by its declaration (issue "One contract for the public
surface": no hand-written check in a body repeats what ``@validates`` already refused).

The source of every module is read with ``ast``. In the body of each ``@validates`` callable
(a class's ``__init__`` and ``__post_init__``, where ``self.<name>`` is the argument) an ``if``
whose branch raises ``ValueError`` or ``TypeError`` (or ``raise refuse(...)``) is a *re-check*
when its test, or one operand of its ``or``, is one of these patterns on a single declared
argument ``a``, and the declaration (evaluated from the decorator's own source) already
excludes every value that would make it true:

* ``not isinstance(a, T)``: every value the declaration accepts is an instance of ``T`` (for an
  ``Interval``: builtin and numpy numbers of its kind);
* ``a < c``, ``a <= c``, ``a > c``, ``a >= c`` with ``c`` a number or an UPPER_CASE constant:
  the declaration is an ``Interval`` whose bound makes the comparison false;
* ``a not in C`` with ``C`` a literal tuple/list/set or an UPPER_CASE constant: the
  declaration is ``Options`` whose options all lie in ``C``.

* a call of a ``check_*`` helper of :mod:`qdensity.validation` whose first argument is ``a``
  and whose other arguments are constants (``check_circuit``, ``check_positive_int``,
  ``check_num_qubits``, ``check_layers``, ``check_seed``, ``check_callable``, ``check_engine``,
  ``check_target``, ``check_type``, ``check_sequence_of``, ``check_real_scalar``,
  ``check_nonnegative_float``, ``check_real_vector``, ``check_finite_array``): every value
  the declaration accepts passes the helper (None too, unless the call sits under
  ``if a is not None:``). Conversions (``as_rng``, ``seed_int``, ``as_parameter_rows``) and
  helpers that check more than any declaration says (``check_distribution``, ``check_width``)
  are not reported.

A comparison with anything else (another argument, a length, a value read from the data) is a
cross-argument check and is never reported; so is a check stricter than its declaration, or a
helper given a bound computed from other values. The oracle is the declaration itself; the
checker is tried on hand-written sources below.
"""

from __future__ import annotations

import ast
import importlib
import textwrap
from pathlib import Path

import numpy as np
import pytest

import qdensity
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    MAX_LAYERS,
    Array,
    CallableC,
    Circuit,
    EngineLike,
    Instance,
    Interval,
    Options,
    Seed,
    SequenceOf,
    TargetLike,
    Unchecked,
    as_constraint,
)

ROOT = Path(qdensity.__file__).resolve().parent

#: Re-checks left for now: ``"module:callable:argument"`` -> why.
ALLOWED: dict[str, str] = {}

_COMPARE = {ast.Lt: "lt", ast.LtE: "le", ast.Gt: "gt", ast.GtE: "ge"}


def _is_constant(node) -> bool:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return True
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return _is_constant(node.operand)
    if isinstance(node, ast.Name):
        return node.id.isupper()
    return isinstance(node, ast.Attribute) and node.attr.isupper()


def _is_container(node) -> bool:
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return all(isinstance(e, ast.Constant) for e in node.elts)
    return isinstance(node, ast.Name) and node.id.isupper()


def _members(constraint) -> list:
    """The alternatives of a declaration (a declared list), None left out."""
    members = getattr(constraint, "members", [constraint])
    return [m for m in members if type(m).__name__ != "_IsNone"]


def _instances_of(constraint, types) -> bool:
    """Whether every value ``constraint`` accepts is an instance of ``types``."""
    if isinstance(constraint, Circuit):
        from qiskit.circuit import QuantumCircuit

        return issubclass(QuantumCircuit, types)
    if isinstance(constraint, Instance):
        return all(issubclass(t, types) for t in constraint.types)
    if isinstance(constraint, Interval):  # the numbers a caller passes: builtin and numpy
        kinds = (int, np.integer) if constraint.kind is int else (int, float, np.integer,
                                                                   np.floating)
        return all(issubclass(k, types) for k in kinds)
    if isinstance(constraint, Options):
        return all(isinstance(o, types) for o in constraint.options)
    if isinstance(constraint, SequenceOf):
        return issubclass(list, types) and issubclass(tuple, types) and issubclass(range, types)
    return False


def _excluded_by_interval(constraint, op: str, c) -> bool:
    """Whether no value in the interval makes ``value <op> c`` true (a ``Seed``'s ints are
    the interval ``[0, high]``; its None and Generator are not compared, so a comparison of
    them sits behind a guard)."""
    if isinstance(constraint, Seed):
        constraint = Interval(int, 0, constraint.high)
    if not isinstance(constraint, Interval):
        return False
    low_closed = constraint.closed in ("both", "left")
    high_closed = constraint.closed in ("both", "right")
    lo, hi = constraint.low, constraint.high
    if op in ("lt", "le"):
        return lo is not None and (lo > c or (lo == c and (op == "lt" or not low_closed)))
    return hi is not None and (hi < c or (hi == c and (op == "gt" or not high_closed)))


def _int_within(m, minimum, maximum) -> bool:
    """Whether the declared alternative ``m`` holds only ints in ``[minimum, maximum]``."""
    return (isinstance(m, Interval) and m.kind is int and _excluded_by_interval(m, "lt", minimum)
            and (maximum is None or _excluded_by_interval(m, "gt", maximum)))


def _finite_real_array(m, ndim=None, min_size: int = 0) -> bool:
    return (isinstance(m, Array) and m.dtype in ("real", "int", "bool")
            and (m.finite or m.dtype != "real") and m.min_size >= min_size
            and (ndim is None or m.ndim == (ndim,)))


_BOUNDS = {"check_positive_int": None, "check_num_qubits": MAX_CIRCUIT_QUBITS,
           "check_layers": MAX_LAYERS}
#: Helpers that let None through (the others refuse it).
_NONE_OK = ("check_seed", "check_target")


def _helper_implied(fn: str, call, members: list, allows_none: bool, scope) -> bool:
    """Whether every value of the declaration (``members``, and None when ``allows_none``)
    passes the helper ``fn`` as ``call`` calls it (its other arguments constants)."""
    def value(node):
        return eval(compile(ast.Expression(node), "<argument>", "eval"), scope)

    kw = {}
    for k in call.keywords:
        if k.arg in ("name", "what", "expected", "why"):
            continue
        if not (_is_constant(k.value) or (isinstance(k.value, ast.Constant)
                                          and k.value.value in (True, False, None))):
            return False  # a bound computed from other values: a cross-argument check
        kw[k.arg] = value(k.value)
    if not members or (allows_none and fn not in _NONE_OK and not kw.get("allow_none")):
        return False
    if fn == "check_circuit":
        from qiskit.circuit import QuantumCircuit

        return all(_instances_of(m, QuantumCircuit) for m in members)
    if fn in _BOUNDS:
        maximum = kw.get("maximum", _BOUNDS[fn])
        return all(_int_within(m, kw.get("minimum", 1), maximum) for m in members)
    if fn == "check_seed":
        return all(isinstance(m, Seed) or _int_within(m, 0, None) for m in members)
    if fn in ("check_real_scalar", "check_nonnegative_float"):
        low = 0 if fn == "check_nonnegative_float" else None
        return all(isinstance(m, Interval) and (low is None or _excluded_by_interval(m, "lt", low))
                   for m in members)
    simple = {"check_callable": CallableC, "check_engine": EngineLike, "check_target": TargetLike}
    if fn in simple:
        return all(isinstance(m, simple[fn]) for m in members)
    if fn in ("check_type", "check_sequence_of") and len(call.args) >= 3:
        types = value(call.args[2])
        if fn == "check_type":
            return all(_instances_of(m, types) for m in members)
        return all(isinstance(m, SequenceOf) and all(_instances_of(i, types)
                                                     for i in _members(m.item)) for m in members)
    if fn == "check_real_vector":
        return all(_finite_real_array(m, 1, kw.get("min_length", 1)) for m in members)
    if fn == "check_finite_array" and len(call.args) == 2 and kw.get("shape") is None:
        return all(_finite_real_array(m) for m in members)
    return False


def _argument(node, names: set[str], post_init: bool) -> str | None:
    if isinstance(node, ast.Name) and node.id in names:
        return node.id
    if (post_init and isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
            and node.value.id == "self" and node.attr in names):
        return node.attr
    return None


def _rechecks(test, names, post_init, declared, scope) -> list[str]:
    """Arguments whose declaration already refuses what ``test`` (or an ``or`` operand) tests."""
    operands = test.values if isinstance(test, ast.BoolOp) and isinstance(test.op, ast.Or) \
        else [test]
    found = []
    for node in operands:
        if (isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not)
                and isinstance(node.operand, ast.Call)
                and getattr(node.operand.func, "id", None) == "isinstance"
                and len(node.operand.args) == 2):
            arg = _argument(node.operand.args[0], names, post_init)
            if arg:
                types = eval(compile(ast.Expression(node.operand.args[1]), "<types>", "eval"),
                             scope)
                if all(_instances_of(m, types) for m in _members(declared[arg])):
                    found.append(arg)
        elif isinstance(node, ast.Compare) and len(node.ops) == 1:
            arg = _argument(node.left, names, post_init)
            op, right = node.ops[0], node.comparators[0]
            if arg and type(op) in _COMPARE and _is_constant(right):
                c = eval(compile(ast.Expression(right), "<bound>", "eval"), scope)
                if all(_excluded_by_interval(m, _COMPARE[type(op)], c)
                       for m in _members(declared[arg])):
                    found.append(arg)
            elif arg and isinstance(op, ast.NotIn) and _is_container(right):
                allowed = eval(compile(ast.Expression(right), "<options>", "eval"), scope)
                members = _members(declared[arg])
                if members and all(isinstance(m, Options) and set(m.options) <= set(allowed)
                                   for m in members):
                    found.append(arg)
    return found


def _raises_value_or_type_error(body) -> bool:
    for stmt in body:
        if isinstance(stmt, ast.Raise) and isinstance(stmt.exc, ast.Call):
            name = getattr(stmt.exc.func, "id", getattr(stmt.exc.func, "attr", None))
            if name in ("ValueError", "TypeError", "refuse"):
                return True
    return False


def _walk_own(node, guarded: frozenset = frozenset()):
    """``(node, guarded)`` for the nodes of a function body (nested functions and classes left
    out); ``guarded`` holds the sources of the expressions an enclosing ``if x is not None:``
    keeps from being None."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        yield child, guarded
        if (isinstance(child, ast.If) and isinstance(child.test, ast.Compare)
                and isinstance(child.test.ops[0], ast.IsNot)
                and isinstance(child.test.comparators[0], ast.Constant)
                and child.test.comparators[0].value is None):
            inner = guarded | {ast.unparse(child.test.left)}
            yield child.test, guarded
            for stmt in child.body:
                yield stmt, inner
                yield from _walk_own(stmt, inner)
            for stmt in child.orelse:
                yield stmt, guarded
                yield from _walk_own(stmt, guarded)
        else:
            yield from _walk_own(child, guarded)


def redundant_checks(source: str, scope: dict) -> list[tuple[str, str, int]]:
    """``(callable, argument, line)`` of every re-check in ``source``; the declarations are
    evaluated in ``scope`` (the module's globals)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            continue
        decorators = [d for d in node.decorator_list if isinstance(d, ast.Call)
                      and getattr(d.func, "id", getattr(d.func, "attr", None)) == "validates"]
        if not decorators:
            continue
        declared = {}
        for kw in decorators[0].keywords:
            value = eval(compile(ast.Expression(kw.value), "<declaration>", "eval"), scope)
            if not isinstance(as_constraint(value), Unchecked):
                declared[kw.arg] = as_constraint(value)
        bodies = [(node, False)] if isinstance(node, ast.FunctionDef) else [
            (f, f.name == "__post_init__") for f in node.body
            if isinstance(f, ast.FunctionDef) and f.name in ("__init__", "__post_init__")]
        for body, post_init in bodies:
            for stmt, guarded in _walk_own(body):
                if isinstance(stmt, ast.If) and _raises_value_or_type_error(stmt.body):
                    for arg in _rechecks(stmt.test, set(declared), post_init, declared, scope):
                        out.append((node.name, arg, stmt.lineno))
                fn = getattr(getattr(stmt, "func", None), "id", None) or getattr(
                    getattr(stmt, "func", None), "attr", "")
                if isinstance(stmt, ast.Call) and fn.startswith("check_") and stmt.args:
                    arg = _argument(stmt.args[0], set(declared), post_init)
                    if arg is None:
                        continue
                    allows_none = (declared[arg].is_satisfied_by(None)
                                   and ast.unparse(stmt.args[0]) not in guarded)
                    if _helper_implied(fn, stmt, _members(declared[arg]), allows_none, scope):
                        out.append((node.name, arg, stmt.lineno))
    return out


def _modules() -> list[str]:
    return sorted(".".join(("qdensity", *p.relative_to(ROOT).with_suffix("").parts))
                  for p in ROOT.rglob("*.py") if "@validates" in p.read_text(encoding="utf-8"))


@pytest.mark.parametrize("module", _modules())
def test_no_body_repeats_a_declaration(module):
    mod = importlib.import_module(module.removesuffix(".__init__"))
    source = Path(mod.__file__).read_text(encoding="utf-8")
    found = sorted({f"{module}:{fn}:{arg} (line {line})" for fn, arg, line in
                    redundant_checks(source, vars(mod))
                    if f"{module}:{fn}:{arg}" not in ALLOWED})
    assert not found, ("these body checks repeat what the declaration already refuses; delete "
                       f"them: {found}")


# ------------------------------------------------------------------ the checker, on oracles

_SCOPE = {"validates": None, "Interval": Interval, "Options": Options, "Instance": Instance,
          "Unchecked": Unchecked, "MAX": 10, "MODES": ("a", "b", "c"), "np": np,
          "Circuit": Circuit, "Seed": Seed, "CallableC": CallableC, "SequenceOf": SequenceOf,
          "Array": Array}


def _found(source: str) -> list[tuple[str, int]]:
    return [(arg, line) for _, arg, line in redundant_checks(textwrap.dedent(source), _SCOPE)]


def test_the_checker_reports_repeated_bounds_types_and_options():
    src = """
    @validates(n=Interval(int, 1, MAX), mode=Options(("a", "b")), s=Instance(str))
    def f(n, mode, s):
        if n < 1:
            raise ValueError("n")
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n > MAX:
            raise ValueError("n")
        if mode not in MODES:
            raise ValueError("mode")
        if not isinstance(s, str):
            raise TypeError("s")
    """
    assert _found(src) == [("n", 4), ("n", 6), ("n", 6), ("mode", 8), ("s", 10)]


def test_the_checker_leaves_stricter_and_cross_argument_checks():
    src = """
    @validates(n=Interval(int, 0), k=Interval(int, 1), mode=Options(("a", "b", "z")),
               u=Unchecked("checked here"), s=Instance(str))
    def f(n, k, mode, u, s):
        if n < 1:                     # stricter than n >= 0
            raise ValueError("n")
        if k > n:                     # two arguments
            raise ValueError("k")
        if n > MAX:                   # no upper bound declared
            raise ValueError("n")
        if mode not in MODES:         # 'z' is declared but refused here
            raise ValueError("mode")
        if not isinstance(n, int):    # refuses numpy ints: stricter
            raise TypeError("n")
        if not isinstance(u, int):    # undeclared (Unchecked): the body is the check
            raise TypeError("u")
        if not s:                     # an empty str: stricter
            raise ValueError("s")
        def inner(n):
            if n < 0:
                raise ValueError("n")
    """
    assert _found(src) == []


def test_the_checker_reads_post_init_through_self():
    src = """
    @validates(p=Interval(float, 0, 1, closed="neither"))
    class C:
        def __post_init__(self):
            if not 0 < self.p < 1 or self.p <= 0:
                raise ValueError("p")
    """
    assert _found(src) == [("p", 5)]


def test_the_checker_reports_helper_calls_the_declaration_implies():
    src = """
    @validates(c=Circuit(), n=Interval(int, 2, 8), m=[Interval(int, 1, MAX), None],
               s=Seed(), f=CallableC(), t=Instance(str), q=SequenceOf(Instance(str)),
               v=Array(ndim=1, min_size=2), r=Interval(float, 0))
    def f(c, n, m, s, f, t, q, v, r):
        check_circuit(c)
        n = check_positive_int(n, "n", maximum=MAX)
        if m is not None:
            check_positive_int(m, "m")
        check_seed(s)
        check_callable(f, "f", "a callable")
        check_type(t, "t", str, "a str")
        check_sequence_of(q, "q", str, "str")
        check_real_vector(v, "v", min_length=2)
        check_nonnegative_float(r, "r")
    """
    assert [arg for arg, _ in _found(src)] == ["c", "n", "m", "s", "f", "t", "q", "v", "r"]


def test_the_checker_reads_a_seed_as_the_ints_it_allows():
    src = """
    @validates(seed=Seed(), other=Seed(10))
    def f(seed, other):
        if seed is not None and not isinstance(seed, np.random.Generator):
            if seed < 0:
                raise ValueError("seed")
        if other >= 5:                         # stricter than Seed(10)
            raise ValueError("other")
    """
    assert _found(src) == [("seed", 5)]


def test_the_checker_leaves_stricter_and_cross_argument_helper_calls():
    src = """
    @validates(c=[Circuit(), None], n=Interval(int, 0), k=Interval(int, 1, MAX),
               a=Array(ndim=1), t=Instance(object), v=Array(ndim=(1, 2)),
               u=Unchecked("checked here"), x=Interval(float))
    def f(c, n, k, a, t, v, u, x):
        check_circuit(c)                          # None is declared, the helper refuses it
        check_positive_int(n, "n")                # n = 0 is declared
        check_positive_int(k, "k", maximum=n)     # a bound from another argument
        check_positive_int(k, "k", maximum=5)     # stricter than k <= MAX
        check_distribution(a, "a")                # sums to one: more than any declaration
        check_type(t, "t", str, "a str")          # stricter type
        check_real_vector(v, "v")                 # 2-d arrays are declared
        check_positive_int(u, "u")                # undeclared (Unchecked)
        check_nonnegative_float(x, "x")           # negative numbers are declared
        y = as_rng(n)                             # a conversion, not a check
    """
    assert _found(src) == []


def test_the_allow_list_names_only_rechecks_that_remain():
    remaining = set()
    for module in {key.split(":")[0] for key in ALLOWED}:
        mod = importlib.import_module(module.removesuffix(".__init__"))
        source = Path(mod.__file__).read_text(encoding="utf-8")
        remaining |= {f"{module}:{fn}:{arg}" for fn, arg, _ in redundant_checks(source, vars(mod))}
    stale = sorted(set(ALLOWED) - remaining)
    assert not stale, f"these allow-listed re-checks are gone; remove them from ALLOWED: {stale}"
