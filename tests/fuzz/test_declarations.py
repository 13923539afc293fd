"""Every public callable declares what each of its arguments accepts (issue "One contract for
the public surface", item 1), and the declarations agree with themselves.

The public surface is every function and class in every package's ``__all__`` (``_api.py``).
A callable passes when each argument a caller gives it (``self``, ``*args`` and ``**kwargs``
aside) has a declaration, every declared name is one of its arguments, and every default value
satisfies its own declaration. Callables without arguments are listed, with the reason, in
``_api.NO_ARGUMENTS``.
"""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest
from _api import NO_ARGUMENTS, NOT_DECLARED, declarations, parameters, public_callables

from qdensity.validation import (
    Array,
    FilePath,
    Instance,
    Interval,
    Options,
    Seed,
    SequenceOf,
    Unchecked,
    validates,
)

PUBLIC = public_callables()


def test_the_public_surface_is_found():
    # a few names every release has exported: the enumeration must reach every layer
    for name in ("qdensity.circuits.loaders.unary_loader", "qdensity.models.density.DensityQNN",
                 "qdensity.execution.exact.ExactEngine", "qdensity.hardware.targets.get_target",
                 "qdensity.learning.estimators.QNNClassifier", "qdensity.cluster.parse_cluster"):
        assert name in PUBLIC
    assert len(PUBLIC) > 140


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_every_argument_is_declared(name):
    obj = PUBLIC[name]
    if name in NOT_DECLARED:
        pytest.fail(f"{name} is not declared: {NOT_DECLARED[name]}")
    params = parameters(obj)
    if name in NO_ARGUMENTS:
        assert not params, f"{name} is allow-listed as taking no arguments but takes {params}"
        return
    decl = declarations(obj)
    missing = sorted(set(params) - set(decl))
    assert decl, f"{name} declares none of its arguments {sorted(params)}"
    assert not missing, f"{name} does not declare {missing}"
    unknown = sorted(set(decl) - set(params))
    assert not unknown, f"{name} declares {unknown}, which are not its arguments"


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_defaults_satisfy_their_declarations(name):
    obj = PUBLIC[name]
    decl = declarations(obj)
    defaults = {arg: p.default for arg, p in parameters(obj).items()
                if p.default is not inspect.Parameter.empty}
    if dataclasses.is_dataclass(obj):  # a default_factory's value, not its placeholder
        defaults.update({f.name: f.default_factory() for f in dataclasses.fields(obj)
                         if f.default_factory is not dataclasses.MISSING})
    for arg, default in defaults.items():
        if arg in decl:
            assert decl[arg].is_satisfied_by(default), (
                f"{name}: the default {arg}={default!r} is not {decl[arg]}")


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_examples_satisfy_and_violations_violate(name):
    for arg, c in declarations(PUBLIC[name]).items():
        if isinstance(c, Unchecked):
            continue
        try:
            example = c.example()
        except LookupError:  # an object only the library makes (a result): none to give
            example = None
        else:
            assert c.is_satisfied_by(example), f"{name}: example of {arg} is not {c}"
        bad = c.violations()
        assert bad, f"{name}: {arg} ({c}) has no violating values for the fuzzer"
        for v in bad:
            assert not c.is_satisfied_by(v), f"{name}: {arg}: {v!r} listed as violating {c}"


# ----------------------------------------------------------------- the vocabulary, on oracles

def test_interval_bounds_by_hand():
    closed = Interval(int, 1, 3)
    assert [closed.is_satisfied_by(v) for v in (0, 1, 3, 4)] == [False, True, True, False]
    half = Interval(float, 0, 1, closed="left")
    assert [half.is_satisfied_by(v) for v in (0.0, 0.5, 1.0)] == [True, True, False]
    assert not half.is_satisfied_by(float("nan"))
    assert not closed.is_satisfied_by(True)  # a bool is not a count
    assert closed.is_satisfied_by(np.int64(2))
    assert not closed.is_satisfied_by(2.0)


def test_array_checks_shape_dtype_and_finiteness_without_copying():
    c = Array(shape=(None, 3))
    assert c.is_satisfied_by(np.zeros((2, 3)))
    assert not c.is_satisfied_by(np.zeros((2, 4)))
    assert not c.is_satisfied_by(np.zeros((2, 3), dtype=complex))
    assert not c.is_satisfied_by(np.full((2, 3), np.inf))
    assert not c.is_satisfied_by(np.zeros((0, 3)))
    assert Array(dtype="int", ndim=1).is_satisfied_by([1, 2])
    assert not Array(dtype="int", ndim=1).is_satisfied_by([1.5, 2])


def test_paths_options_seeds_sequences(tmp_path):
    f = tmp_path / "f.txt"
    f.write_text("x")
    assert FilePath().is_satisfied_by(f) and not FilePath().is_satisfied_by(tmp_path)
    assert not FilePath().is_satisfied_by(tmp_path / "missing")
    assert Options(["a", "b"]).is_satisfied_by("a") and not Options(["a"]).is_satisfied_by("c")
    assert Seed().is_satisfied_by(np.random.default_rng(0)) and not Seed().is_satisfied_by(-1)
    assert SequenceOf(Interval(int, 0)).is_satisfied_by([0, 1])
    assert not SequenceOf(Interval(int, 0)).is_satisfied_by([0, -1])
    assert not Instance(int).is_satisfied_by(True)


def test_the_decorator_names_callable_argument_value_and_allowed():
    @validates(n=Interval(int, 1, 5), name=Options(["a"]))
    def f(n, name="a"):
        return n

    assert f(2) == 2 and f.__constraints__["n"].high == 5
    with pytest.raises(ValueError, match=r"f: n must be an int >= 1 and <= 5, got 9"):
        f(9)
    with pytest.raises(TypeError, match=r"f: name must be 'a', got 3"):
        f(1, name=3)
    with pytest.raises(TypeError, match=r"f: missing a required argument: 'n'"):
        f()
    long = "x" * 500
    with pytest.raises(ValueError) as info:
        f(1, name=long)
    assert len(str(info.value)) < 200  # the value's repr is cut


def test_the_decorator_refuses_declaring_an_unknown_argument():
    with pytest.raises(TypeError, match="no parameters"):
        validates(m=int)(lambda n: n)


def test_a_class_declares_its_constructor():
    @validates(k=Interval(int, 0))
    class C:
        def __init__(self, k):
            self.k = k

    assert C(1).k == 1 and "k" in C.__constraints__
    with pytest.raises(ValueError, match="C: k must be"):
        C(-1)


def test_the_sweep_command_offers_exactly_the_estimators_options():
    import argparse

    from qdensity.cli import sweep
    from qdensity.learning import _spec

    sub = argparse.ArgumentParser().add_subparsers()
    sweep.add_parser(sub, lambda lo, hi: int, int, 8)
    text = " ".join(sub.choices["sweep"].format_help().split())
    for name in ("ansatz", "decomposition", "mixture"):
        options = _spec.PARAMETER_CONSTRAINTS[name].options
        assert f"--{name} {{{','.join(options)}}}" in text, name


def test_sweep_with_an_unknown_ansatz_is_refused_by_argparse_before_optuna(tmp_path, capsys):
    from qdensity.cli.main import main

    db = tmp_path / "study.db"
    with pytest.raises(SystemExit) as info:
        main(["sweep", "--ansatz", "bogus", "--storage", f"sqlite:///{db}"])
    assert info.value.code == 2
    assert "--ansatz" in capsys.readouterr().err and not db.exists()
