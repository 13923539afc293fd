"""Fuzzing the ``qdensity`` command in-process: every subcommand with random bad arguments
exits with status 2 and a one-line message on stderr, never a traceback."""

from __future__ import annotations

import contextlib
import io
import os
import tempfile

from _fuzz import TALLY
from hypothesis import given, settings
from hypothesis import strategies as st

from qdensity.cli import main
from qdensity.cli.main import BUILDERS

BAD_INT = st.one_of(st.integers(-10**6, 0).map(str), st.integers(10**5, 10**15).map(str),
                    st.sampled_from(["1.5", "abc", "", "nan", "inf", "0x10", "--"]))
BAD_FLOAT = st.sampled_from(["nan", "inf", "-inf", "abc", "", "1e999"])
BAD_SEED = st.sampled_from(["-1", "-7", "abc", "1.5", "", str(2**32), str(2**40), "nan"])
NAME = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_0123456789", min_size=1, max_size=12)


def run_cli(entry: str, argv: list[str]) -> None:
    """``main(argv)`` must end with status 2 and one line on stderr."""
    TALLY[f"qdensity {entry}"] += 1
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse usage errors
            code = exc.code
    text = err.getvalue().strip()
    assert code == 2, f"{argv}: exit status {code}, stderr {text!r}"
    assert "Traceback" not in text, f"{argv}: {text}"
    assert text and len(text.splitlines()) == 1, f"{argv}: stderr is not one line: {text!r}"
    assert text.startswith("qdensity"), text


@settings(max_examples=30)
@given(data=st.data())
def test_build_and_transpile_bad_arguments(data):
    cmd = data.draw(st.sampled_from(["build", "transpile"]))
    name = data.draw(st.sampled_from(sorted(BUILDERS)))
    kind = data.draw(st.sampled_from(["name", "size", "seed", "fold", "target", "level",
                                      "flag"]))
    argv = [cmd, name]
    if kind == "name":
        argv[1] = data.draw(NAME.filter(lambda s: s not in BUILDERS))
    elif kind == "size":
        argv += ["--size", data.draw(BAD_INT)]
    elif kind == "seed":
        argv += ["--seed", data.draw(BAD_SEED)]
    elif kind == "fold" and cmd == "build":
        argv += ["--fold", data.draw(st.sampled_from(["-5", "abc", "100000", "1.5"]))]
    elif kind == "target" and cmd == "transpile":
        argv += ["--target", data.draw(NAME.filter(lambda s: s not in (
            "ideal", "heavy_hex", "line", "grid", "all_to_all")))]
    elif kind == "level" and cmd == "transpile":
        argv += ["--optimization-level", data.draw(st.sampled_from(["4", "-1", "x", "1.0"]))]
    else:
        argv += ["--" + data.draw(NAME)]
    run_cli(cmd, argv)


@settings(max_examples=30)
@given(data=st.data())
def test_run_bad_arguments(data):
    kind = data.draw(st.sampled_from(["size", "shots", "alpha", "alpha_sum", "x", "scheduler",
                                      "target", "seed", "few_shots"]))
    argv = ["run", "--size", "4"]
    if kind == "size":
        argv[2] = data.draw(st.one_of(BAD_INT, st.sampled_from(["1", "17", "40"])))
    elif kind == "shots":
        argv += ["--shots", data.draw(st.one_of(BAD_INT.filter(lambda s: not s.isdigit()
                                                              or int(s) > 10**8
                                                              or int(s) <= 0)))]
    elif kind == "alpha":
        argv += ["--alpha", *data.draw(st.lists(BAD_FLOAT, min_size=1, max_size=3))]
    elif kind == "alpha_sum":
        argv += ["--alpha", *[str(2.0)] * data.draw(st.integers(1, 5))]
    elif kind == "x":
        k = data.draw(st.sampled_from([1, 2, 3, 5, 9]))
        argv += ["--x", *["0.5"] * k]
    elif kind == "scheduler":
        argv += ["--scheduler", data.draw(NAME)]
    elif kind == "target":
        argv += ["--target", data.draw(NAME.filter(lambda s: s not in (
            "ideal", "heavy_hex", "line", "grid", "all_to_all")))]
    elif kind == "few_shots":
        argv += ["--shots", "1", "--scheduler", data.draw(st.sampled_from(["proportional",
                                                                          "neyman"]))]
    else:
        argv += ["--seed", data.draw(BAD_SEED)]
    run_cli("run", argv)


@settings(max_examples=30)
@given(data=st.data())
def test_table1_export_demo_bad_arguments(data):
    cmd = data.draw(st.sampled_from(["table1", "export", "demo"]))
    with tempfile.TemporaryDirectory() as tmp:
        a_file = os.path.join(tmp, "file.txt")
        with open(a_file, "w") as fh:
            fh.write("x")
        missing = os.path.join(tmp, "missing", "dir")
        if cmd == "table1":
            kind = data.draw(st.sampled_from(["n", "ansatz", "layers", "copies"]))
            if kind == "n":
                argv = ["table1", "--n", data.draw(BAD_INT)]
            elif kind == "ansatz":
                argv = ["table1", "--n", "4", "--ansatz", data.draw(NAME)]
            else:
                argv = ["table1", "--n", "4", f"--{kind}", data.draw(BAD_INT)]
        elif cmd == "export":
            argv = data.draw(st.sampled_from([["export", missing, "--check"],
                                               ["export", a_file], ["export", a_file, "--check"],
                                               ["export", os.path.join(a_file, "sub")]]))
        else:
            kind = data.draw(st.sampled_from(["budget", "shots", "seed", "output"]))
            argv = (["demo", "--output", missing] if kind == "output"
                    else ["demo", "--seed", data.draw(BAD_SEED)] if kind == "seed"
                    else ["demo", f"--{kind}", data.draw(BAD_INT)])
        run_cli(cmd, argv)


def test_unknown_subcommand_and_no_arguments():
    run_cli("(none)", [])
    run_cli("(none)", ["frobnicate"])
    run_cli("(none)", ["--size", "4"])


@settings(max_examples=5, deadline=None)
@given(budget=st.integers(1, 799))
def test_demo_budget_below_one_step_exits_2(budget):
    """A quick-demo step costs 2 points x 25 circuits x 16 shots = 800 shots (pure model)."""
    with tempfile.TemporaryDirectory() as out:
        run_cli("demo", ["demo", "--quick", "--budget", str(budget), "--output", out])
        assert not os.listdir(out)
