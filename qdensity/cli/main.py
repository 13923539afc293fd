"""The ``qdensity`` command: build, transpile, run, table1, export, demo, sweep, experiment.

Every sub-command has ``--help`` (with help text for every option) and ``--json``, which prints
one JSON document on stdout whose field names are those of the Python result (a circuit's
``num_qubits`` / ``size`` / ``depth``, a ``ResourceReport``, a ``ScheduleResult``, the rows of
``table1``, the dict ``run_demo`` returns); progress bars, when a terminal shows them, go to
stderr. Bad input (an unknown builder or target, a budget smaller than the circuits) prints a
clear message and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from collections.abc import Callable

import numpy as np

from qdensity.cli._builders import BUILDERS, _vector, build_circuit, check_size
from qdensity.cli._devices import DEMO_OPTIONS, correction_options, corrections
from qdensity.cli._help import Formatter, texts
from qdensity.io import atomic_write_text
from qdensity.validation import Instance, SequenceOf, validates

__all__ = ["main", "BUILDERS", "build_circuit", "MAX_CLI_QUBITS", "MAX_CLI_SHOTS"]

#: Widest circuit the ``build``, ``transpile`` and ``table1`` commands build.
MAX_CLI_QUBITS = 64
#: Widest model ``run`` simulates with shots on a (noisy) target.
MAX_RUN_QUBITS = 16
#: Largest shot budget a command accepts.
MAX_CLI_SHOTS = 10**8


class _Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line on stderr and exit status 2, and whose
    ``--help`` shows every option's default and keeps the description's and the examples' line
    breaks (sub-commands' parsers are of this class too)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # noqa: D102 - argparse API
        message = " ".join(str(message).split())
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _int_in(low: int, high: int) -> Callable[[str], int]:
    """An argparse ``type``: an int in ``[low, high]``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in [{low}, {high}], got {value}")
        return value

    parse.__name__ = "int"
    return parse


def _finite_float(text: str) -> float:
    """An argparse ``type``: a finite real number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


_finite_float.__name__ = "float"
_SEED = _int_in(0, 2**32 - 1)


def _print_json(obj) -> None:
    """One JSON document on stdout (numpy scalars and arrays as plain numbers and lists)."""
    print(json.dumps(obj, indent=2, default=lambda o: o.tolist() if hasattr(o, "tolist")
                     else str(o)))


def _qasm_text(qc, version: int) -> str:
    """OpenQASM 3 of ``qc`` (its gates defined in the file, parameters kept as inputs), or
    OpenQASM 2 unrolled into ``qelib1.inc`` gates (parameters must be bound)."""
    if version == 3:
        from qiskit import qasm3

        return qasm3.dumps(qc)
    if qc.num_parameters:
        raise ValueError("OpenQASM 2 has no free parameters: drop --unbound, or use "
                         "--qasm-version 3 (the default)")
    from qiskit import qasm2, transpile

    from qdensity.cli.export import QASM2_BASIS

    return qasm2.dumps(transpile(qc, basis_gates=list(QASM2_BASIS), optimization_level=0))


def _cmd_build(args) -> int:
    check_size(args.name, args.size, MAX_CLI_QUBITS)
    qc = build_circuit(args.name, args.size, bind_seed=None if args.unbound else args.seed)
    out = {"name": args.name, "num_qubits": qc.num_qubits, "num_clbits": qc.num_clbits,
           "size": qc.size(), "depth": qc.depth(), "num_parameters": qc.num_parameters,
           "count_ops": dict(qc.count_ops())}
    if args.qasm and args.qasm != "-":
        from pathlib import Path

        folder = Path(args.qasm).expanduser().resolve().parent
        if not folder.is_dir():
            raise ValueError(f"--qasm {args.qasm!r}: the folder {str(folder)!r} does not exist; "
                             f"create it first (mkdir -p) or choose another path")
    if args.qasm:
        text = _qasm_text(qc, args.qasm_version)
        if args.qasm == "-":
            out["qasm"] = text
            if not args.json:
                print(text)
        else:
            atomic_write_text(args.qasm, text)
            out["qasm_file"] = args.qasm
            if not args.json:
                print(f"wrote {args.qasm}")
    if args.draw or not (args.qasm or args.json):
        drawing = str(qc.draw(output="text", fold=args.fold))
        out["drawing"] = drawing
        if not args.json:
            print(drawing)
    if args.json:
        _print_json(out)
    else:
        print(f"{args.name}: {qc.num_qubits} qubits, {qc.size()} gates, depth {qc.depth()}, "
              f"{qc.num_parameters} free parameters", file=sys.stderr)
    return 0


def _cmd_transpile(args) -> int:
    from qdensity.hardware.resources import resource_report

    check_size(args.name, args.size, MAX_CLI_QUBITS)
    qc = build_circuit(args.name, args.size, bind_seed=args.seed)
    # a name is sized to the circuit; a snapshot file is the device's size; noise off
    report = resource_report(qc, args.target, optimization_level=args.optimization_level,
                             seed=args.seed)
    _print_json(report.as_dict()) if args.json else print(report.table())
    return 0


def _cmd_run(args) -> int:
    from qiskit.quantum_info import SparsePauliOp

    from qdensity.circuits.ansatze import round_robin
    from qdensity.hardware.targets import get_target
    from qdensity.models.decompositions import by_moments
    from qdensity.models.density import DensityQNN, Encoding

    n = args.size
    dec = by_moments(round_robin(n))
    K = dec.num_subunitaries
    alpha = np.full(K, 1.0 / K) if args.alpha is None else np.array(args.alpha, dtype=float)
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN(dec.sub_unitaries, alpha, encoding=Encoding.unary(n), observable=obs,
                       seed=args.seed)
    x = _vector(n, args.seed) if args.x is None else np.array(args.x, dtype=float)
    if x.shape[0] != n:
        raise ValueError(f"--x must have {n} values, got {x.shape[0]}")
    target = get_target(args.target, n, seed=args.seed)
    if args.shots < K and args.scheduler != "per_shot":
        raise ValueError(f"--shots {args.shots} is smaller than the {K} sub-unitary circuits")
    result = model.train().sample(x, args.shots, scheduler=args.scheduler, target=target,
                                  seed=args.seed, **corrections(args))
    exact = float(model.eval().predict(x[None, :])[0])
    pilot = result.pilot_allocation
    out = {"model": f"round_robin_{n} by layers (K={K})", "target": target.label,
           "scheduler": args.scheduler, "budget": args.shots,
           # the ScheduleResult's fields, under their own names
           "estimate": float(result.estimate), "standard_error": float(result.standard_error),
           "allocation": np.asarray(result.allocation).tolist(),
           "pilot_allocation": None if pilot is None else np.asarray(pilot).tolist(),
           "per_subunitary": np.asarray(result.per_subunitary).tolist(),
           "shots_used": int(result.shots_used),
           "exact_noiseless": exact}
    if args.json:
        _print_json(out)
    else:
        for key, val in out.items():
            print(f"{key:>16}: {val}")
    return 0


def _cmd_table1(args) -> int:
    from qdensity.circuits.ansatze.registry import FAMILIES
    from qdensity.gradients.table1 import ANSATZE, format_table1, table1

    unknown = [a for a in args.ansatz if a not in ANSATZE]
    if unknown:
        raise ValueError(f"unknown ansatz {unknown}; known: {', '.join(ANSATZE)}")
    names = args.ansatz or ANSATZE
    odd = [n for n in args.n if n & (n - 1)]
    powers = [name for name in names if FAMILIES[name].power_of_two]  # the family registry's
    if powers and odd:
        print(f"qdensity table1: note: the {' and '.join(powers)} row is dropped for n = "
              f"{', '.join(map(str, odd))} (a {' or '.join(powers)} needs a power-of-two "
              "number of qubits)", file=sys.stderr)
    rows = table1(args.n, names, layers=args.layers, copies_k=args.copies)
    if args.json:
        _print_json(rows)
    else:
        print(format_table1(rows))
    return 0


def _cmd_export(args) -> int:
    from qdensity.cli.export import check_circuits, export_circuits
    from qdensity.cli.export import main as export_main

    if not args.json:
        try:
            return export_main([args.directory] + (["--check"] if args.check else [])
                               + (["--qasm3"] if args.qasm3 else []), prog="qdensity export")
        except SystemExit as exc:  # its usage errors, already printed on one line
            return exc.code if isinstance(exc.code, int) else 2
    # the Python results: check_circuits -> stale names, export_circuits -> written paths
    if args.check:
        stale = check_circuits(args.directory)
        _print_json({"directory": args.directory, "check": True, "stale": stale})
        return 1 if stale else 0
    formats = ("qasm3",) if args.qasm3 else ("qasm", "qasm3")
    paths = export_circuits(args.directory, formats=formats)
    _print_json({"directory": args.directory, "check": False, "paths": [str(p) for p in paths]})
    return 0


def _cmd_demo(args) -> int:
    from pathlib import Path

    from qdensity.demo import DemoConfig, run_demo

    if not args.no_plot and not Path(args.output).is_dir():
        raise ValueError(f"--output {args.output!r} is not an existing directory")

    changes = {k: getattr(args, k) for k in DEMO_OPTIONS if getattr(args, k) is not None}
    cfg = DemoConfig.quick(**changes) if args.quick else DemoConfig(**changes)
    results = run_demo(cfg, output_dir=args.output, plot=not args.no_plot,
                       verbose=not args.json, progress=True,
                       plot_name="qdensity-demo-quick.png" if args.quick else "qdensity-demo.png")
    if args.json:
        _print_json(results)
    return 0


def _parser(demo: bool = True) -> argparse.ArgumentParser:
    """The command's parser; ``demo=False`` leaves out the ``demo`` command's options, whose
    help reads the demo's defaults (importing the training stack: scikit-learn, numba, about
    1.5 s of CPU) -- :func:`main` builds them only when ``demo`` is on the command line."""
    from qdensity.cli import sweep
    from qdensity.cli.plugins import add_plugin_parsers
    from qdensity.hardware.targets import target_help

    any_size = _int_in(-(2**31), 2**31)  # build / transpile: checked with the builder's name
    shots = _int_in(1, MAX_CLI_SHOTS)
    p = _Parser(prog="qdensity", description="Density quantum neural networks "
                                "on Qiskit and qiskit-aer.",
                epilog="examples:\n  qdensity build pyramid --size 6\n  qdensity demo --quick\n"
                       "  qdensity experiment --list\n  qdensity COMMAND --help")
    import importlib

    version = importlib.import_module("qdensity").__version__  # the package root, imported
    p.add_argument("--version", action="version", version=f"%(prog)s {version}")
    sub = p.add_subparsers(dest="command", required=True)

    b = sub.add_parser("build", help="print, draw or export a named circuit", **texts("build"))
    b.add_argument("name", help=f"one of: {', '.join(BUILDERS)}")
    b.add_argument("--size", type=any_size, default=4, help="number of (data) qubits (at least 2; "
                   "reuploading: layers, from 1; equivariant_xx/yy from 3; butterfly: a power "
                   "of two)")
    b.add_argument("--draw", action="store_true",
                   help="draw the circuit (the default without --qasm or --json)%(default).0s")
    b.add_argument("--qasm", metavar="FILE",
                   help="write OpenQASM to FILE ('-' for stdout; default: none)%(default).0s")
    b.add_argument("--qasm-version", type=int, choices=[2, 3], default=3,
                   help="OpenQASM 3 (gate definitions, free parameters as inputs) or 2 "
                        "(qelib1.inc gates, bound parameters)")
    b.add_argument("--unbound", action="store_true", help="keep parameters free")
    b.add_argument("--seed", type=_SEED, default=0, help="seed of the bound parameter values")
    b.add_argument("--fold", type=_int_in(-1, 10**4), default=120,
                   help="drawing width (-1: no folding)")
    b.add_argument("--json", action="store_true",
                   help="print JSON: num_qubits, size, depth, num_parameters, count_ops (and "
                        "qasm / qasm_file / drawing when asked)")
    b.set_defaults(func=_cmd_build)

    t = sub.add_parser("transpile", help="resource report of a named circuit on a target",
                       **texts("transpile"))
    t.add_argument("name", help=f"one of: {', '.join(BUILDERS)}")
    t.add_argument("--size", type=any_size, default=4, help="number of (data) qubits (as for "
                   "build)")
    t.add_argument("--target", default="ideal", help=target_help())
    t.add_argument("--optimization-level", type=int, default=1, choices=[0, 1, 2, 3],
                   help="Qiskit preset pass manager level")
    t.add_argument("--seed", type=_SEED, default=0,
                   help="seed of the bound parameters, the target's sampled errors and the "
                        "transpiler")
    t.add_argument("--json", action="store_true", help="print the report as JSON")
    t.set_defaults(func=_cmd_transpile)

    r = sub.add_parser("run", help="estimate a density model's output on a noisy target "
                                   "under a shot budget", **texts("run"))
    r.add_argument("--size", type=_int_in(2, MAX_RUN_QUBITS), default=6,
                   help="qubits of the round-robin model")
    r.add_argument("--target", default="heavy_hex", help=target_help())
    r.add_argument("--shots", type=shots, default=2000, help="total shot budget")
    r.add_argument("--scheduler", default="proportional",
                   choices=["per_shot", "proportional", "neyman"],
                   help="how the budget is split over the sub-unitaries: per_shot (draw k for "
                        "every shot), proportional (n_k ~ alpha_k) or neyman (a pilot, then "
                        "n_k ~ alpha_k sigma_k; allocation excludes the pilot_allocation)")
    r.add_argument("--alpha", type=_finite_float, nargs="+",
                   help="mixture (default: uniform)%(default).0s")
    r.add_argument("--x", type=_finite_float, nargs="+",
                   help="input vector (default: seeded random)%(default).0s")
    r.add_argument("--seed", type=_SEED, default=0,
                   help="seed of the model, the input, the target's errors and the shots")
    correction_options(r)
    r.add_argument("--json", action="store_true",
                   help="print JSON: estimate, standard_error, allocation, pilot_allocation, "
                        "per_subunitary, shots_used (the ScheduleResult's fields)")
    r.set_defaults(func=_cmd_run)

    tb = sub.add_parser("table1", help="rebuild the paper's Table 1 from real gradient plans",
                        **texts("table1"))
    tb.add_argument("--n", type=_int_in(2, MAX_CLI_QUBITS), nargs="+", default=[4, 8],
                    help="qubit counts (the butterfly row only for powers of two)")
    tb.add_argument("--ansatz", nargs="+", default=[], help="subset of ansätze")
    tb.add_argument("--layers", type=_int_in(1, 100), default=3,
                    help="hardware-efficient depth D")
    tb.add_argument("--copies", type=_int_in(1, 64), default=2,
                    help="K for the equivariant density model")
    tb.add_argument("--json", action="store_true", help="print a JSON list of rows")
    tb.set_defaults(func=_cmd_table1)

    e = sub.add_parser("export", help="write (or --check) the reference OpenQASM circuits",
                       **texts("export"))
    e.add_argument("directory", nargs="?", default="circuits",
                   help="where the .qasm files and their README.md index go")
    e.add_argument("--check", action="store_true",
                   help="only check the files are current (exit status 1 if not)")
    e.add_argument("--qasm3", action="store_true", help="write only the OpenQASM 3 files "
                   "(trainable and data parameters symbolic)")
    e.add_argument("--json", action="store_true",
                   help="print JSON: directory and the written paths (or, with --check, the "
                        "stale names)")
    e.set_defaults(func=_cmd_export)

    d = sub.add_parser("demo", help="train a round-robin OrthoQNN and its density version on "
                                    "digits with sampled gradients on a noisy heavy-hex device "
                                    "at the same shot budget, beside each model's exact-training "
                                    "ceiling (about a minute)", **texts("demo"))
    if demo:
        _demo_options(d, shots)
    d.set_defaults(func=_cmd_demo)

    sweep.add_parser(sub, _int_in, _SEED, MAX_CLI_QUBITS)
    add_plugin_parsers(sub)  # experiment, results: the paper's package (qdensity_paper)
    return p


def _demo_options(d: argparse.ArgumentParser, shots) -> None:
    from qdensity.demo import DemoConfig
    from qdensity.hardware.targets import target_help

    d.add_argument("--output", default=".", help="directory for qdensity-demo.png "
                   "(qdensity-demo-quick.png with --quick)")
    full, quick = DemoConfig(), DemoConfig.quick()
    d.add_argument("--budget", type=shots, help=f"shot budget per model (default: {full.budget}; "
                   f"{quick.budget} with --quick)%(default).0s")
    d.add_argument("--shots", type=shots, help=f"shots per circuit (default: {full.shots})"
                   "%(default).0s")
    d.add_argument("--seed", type=_SEED, default=7,
                   help="seed of the data split, the models, the device's errors and the shots")
    correction_options(d, target_help())
    d.add_argument("--no-plot", action="store_true", help="do not write qdensity-demo.png")
    d.add_argument("--quick", action="store_true",
                   help="a smoke test of the install only (4 qubits, 3 classes, small budget: "
                        "the models are not expected to learn)")
    d.add_argument("--json", action="store_true",
                   help="print JSON instead of text: per model accuracy, ceiling, "
                        "fraction_of_ceiling, circuits, shots, steps, gradient_method, seconds, "
                        "curve; config, plot, seconds (what run_demo returns)")


@validates(argv=[SequenceOf(Instance(str), min_len=0), None])
def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``qdensity`` command; returns the exit status.

    Examples
    --------
    >>> main(["build", "pyramid", "--size", "4", "--json"])
    {
      "name": "pyramid",
      "num_qubits": 4,
      ...
    }
    0
    """
    words = sys.argv[1:] if argv is None else list(argv)
    parser = _parser(demo="demo" in words)
    args = parser.parse_args(words)  # usage errors: one line, SystemExit(2)
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    try:
        return int(args.func(args) or 0)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        message = " ".join(str(exc).split())  # one line
        print(f"qdensity {args.command}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
