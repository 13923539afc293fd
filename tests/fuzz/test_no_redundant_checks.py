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

A comparison with anything else (another argument, a length, a value read from the data) is a
cross-argument check and is never reported; so is a check stricter than its declaration. The
oracle is the declaration itself; the checker is tried on hand-written sources below.
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
    Circuit,
    Instance,
    Interval,
    Options,
    SequenceOf,
    Unchecked,
    as_constraint,
)

ROOT = Path(qdensity.__file__).resolve().parent

#: Re-checks left for now: ``"module:callable:argument"`` -> why.
ALLOWED: dict[str, str] = {
}

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
    """Whether no value in the interval makes ``value <op> c`` true."""
    if not isinstance(constraint, Interval):
        return False
    low_closed = constraint.closed in ("both", "left")
    high_closed = constraint.closed in ("both", "right")
    lo, hi = constraint.low, constraint.high
    if op in ("lt", "le"):
        return lo is not None and (lo > c or (lo == c and (op == "lt" or not low_closed)))
    return hi is not None and (hi < c or (hi == c and (op == "gt" or not high_closed)))


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


def _walk_own(node):
    """The nodes of a function body, nested functions and classes left out."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        yield child
        yield from _walk_own(child)


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
            for stmt in _walk_own(body):
                if isinstance(stmt, ast.If) and _raises_value_or_type_error(stmt.body):
                    for arg in _rechecks(stmt.test, set(declared), post_init, declared, scope):
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
          "Unchecked": Unchecked, "MAX": 10, "MODES": ("a", "b", "c"), "np": np}


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


def test_the_allow_list_names_only_rechecks_that_remain():
    remaining = set()
    for module in {key.split(":")[0] for key in ALLOWED}:
        mod = importlib.import_module(module.removesuffix(".__init__"))
        source = Path(mod.__file__).read_text(encoding="utf-8")
        remaining |= {f"{module}:{fn}:{arg}" for fn, arg, _ in redundant_checks(source, vars(mod))}
    stale = sorted(set(ALLOWED) - remaining)
    assert not stale, f"these allow-listed re-checks are gone; remove them from ALLOWED: {stale}"
