"""``qdensity results``: read, merge and judge experiment results files.

* ``qdensity results show FILE``: the summary table (mean and 95% CI per metric; intervals
  from fewer than 3 seeds and clipped ones are marked);
* ``qdensity results merge A.json B.json ... -o C.json``: one file from runs of the same
  experiment, mode and settings (:func:`qdensity.experiments.merge.merge_results`);
* ``qdensity results report [--dir results] [--write | --check]``: the verdicts by rule
  (:mod:`qdensity.experiments.verdicts`), written into README.md and EXPERIMENTS.md between
  their markers, or checked against them.

Each takes ``--json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

__all__ = ["add_parser"]


def _flags(ci: dict) -> str:
    marks = []
    if ci.get("few_seeds"):
        marks.append("few seeds")
    if ci.get("clipped"):
        marks.append("clipped to range")
    return f"  ({', '.join(marks)})" if marks else ""


def _json(args) -> bool:
    return bool(getattr(args, "json", False))


def _cmd_none(args) -> int:
    raise ValueError("name a sub-command: qdensity results show|merge|report (see --help)")


def _cmd_show(args) -> int:
    from qdensity.experiments.results import ExperimentResult

    result = ExperimentResult.load(args.file)
    if _json(args):
        print(json.dumps({"name": result.name, "mode": result.mode, "seeds": result.seeds,
                          "config": result.config, "summary": result.summary}, indent=2))
        return 0
    print(f"{result.name} ({result.mode}, seeds {result.seeds})")
    for key, ci in result.summary.items():
        print(f"  {key:<44} {ci['mean']:.4g}  [{ci['low']:.4g}, {ci['high']:.4g}]{_flags(ci)}")
    return 0


def _cmd_merge(args) -> int:
    from qdensity.experiments.merge import merge_results
    from qdensity.experiments.results import ExperimentResult

    merged = merge_results([ExperimentResult.load(p) for p in args.files])
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(merged.to_dict(), indent=2) + "\n", encoding="utf-8")
    if _json(args):
        print(json.dumps(merged.to_dict(), indent=2))
    else:
        print(f"merged {len(args.files)} files: {merged.name} ({merged.mode}), seeds "
              f"{merged.seeds} -> {out}")
    return 0


def _cmd_report(args) -> int:
    from qdensity.experiments.verdicts import evaluate, report, splice

    directory = Path(args.dir)
    generated = report(directory)
    if _json(args):
        print(json.dumps(evaluate(sorted(directory.glob("*.json"))), indent=2))
    elif not (args.write or args.check):
        for name, text in generated.items():
            print(f"## {name}\n\n{text}\n")
    drift = []
    for name, text in generated.items():
        path = Path(args.docs) / name
        current = path.read_text(encoding="utf-8")
        updated = splice(current, text, str(path))
        if args.write and updated != current:
            path.write_text(updated, encoding="utf-8")
            print(f"wrote {path}")
        elif args.check and updated != current:
            drift.append(str(path))
    if drift:
        raise ValueError(f"{', '.join(drift)} differ from the report of {str(directory)!r}: run "
                         "qdensity results report --write")
    return 0


def add_parser(sub) -> None:
    """Add the ``results`` sub-command group to ``qdensity``'s sub-parsers."""
    r = sub.add_parser("results", help="show, merge and judge experiment results files")
    r.add_argument("--json", action="store_true",
                   help="print JSON (the same as the sub-command's --json)")
    r.set_defaults(func=_cmd_none)
    rs = r.add_subparsers(dest="results_command", metavar="{show,merge,report}",
                          help="show: a file's summary; merge: files into one; report: verdicts")
    show = rs.add_parser("show", help="print a results file's summary table")
    show.add_argument("file", help="a results JSON (NAME-MODE.json)")
    show.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                      help="print the summary as JSON")
    show.set_defaults(func=_cmd_show)
    merge = rs.add_parser("merge", help="merge runs of one experiment, mode and settings")
    merge.add_argument("files", nargs="+", help="results JSON files")
    merge.add_argument("-o", "--output", required=True, help="the merged file to write")
    merge.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                       help="also print the merged JSON")
    merge.set_defaults(func=_cmd_merge)
    rep = rs.add_parser("report", help="verdicts by rule from the results files; --write puts "
                                       "them into README.md and EXPERIMENTS.md")
    rep.add_argument("--dir", default="results", help="directory of results files")
    rep.add_argument("--docs", default=".", help="directory of README.md and EXPERIMENTS.md")
    mode = rep.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true",
                      help="write the report between the markers of README.md and EXPERIMENTS.md")
    mode.add_argument("--check", action="store_true",
                      help="fail when README.md or EXPERIMENTS.md differ from the report")
    rep.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                     help="print the verdicts as JSON")
    rep.set_defaults(func=_cmd_report)
