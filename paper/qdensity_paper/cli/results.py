"""``qdensity results``: read, merge and judge experiment results files.

* ``qdensity results show FILE [--metric PATTERN]``: the summary table (mean and 95% CI per
  metric, the headline metrics first, then counts and sizes; intervals from fewer than 3 seeds
  and clipped ones are marked);
* ``qdensity results merge A.json B.json ... -o C.json``: one file from runs of the same
  experiment, mode and settings (:func:`qdensity_paper.merge.merge_results`);
* ``qdensity results report [--dir results] [--write | --check]``: the verdicts by rule
  (:mod:`qdensity_paper.verdicts`), printed (any folder; a quick run is shown as
  "quick run: not judged"), or written into README.md and EXPERIMENTS.md between their
  markers, or checked against them (these two need both files in ``--docs``).

Each takes ``--json``.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import re
import textwrap
from pathlib import Path

from qdensity.io import atomic_write_text
from qdensity_paper.cli._help import texts

__all__ = ["add_parser", "is_headline", "print_summary", "QUICK", "WIDTH"]


#: Metrics that count or size a run rather than score it (a path segment matching one of
#: these goes below the headline metrics in ``results show``).
_DETAIL = re.compile(r"circuits|shots|^num_|_rows$|^seconds$|^seed$|^classes$|qubits|^steps$|"
                     r"^runs_of$|parameters|calibration|^trials$")
#: Widest line the commands print.
WIDTH = 100


def _flags(ci: dict) -> str:
    marks = []
    if ci.get("few_seeds"):
        marks.append("few seeds")
    if ci.get("clipped"):
        marks.append("clipped")
    return f" ({', '.join(marks)})" if marks else ""


def _json(args) -> bool:
    return bool(getattr(args, "json", False))


def _cmd_none(args) -> int:
    raise ValueError("name a sub-command: qdensity results show|merge|report (see --help)")


def is_headline(key: str) -> bool:
    """True for a metric that scores the run (accuracy, loss, error, a bound), False for one
    that counts or sizes it (circuits, shots, qubits, seconds, parameters)."""
    return not any(_DETAIL.search(part) for part in key.split("/"))


def _matches(key: str, patterns: list[str]) -> bool:
    """A shell-style pattern (``*accuracy``) or, without wildcards, a substring of the key."""
    return any(fnmatch.fnmatchcase(key, p) if any(c in p for c in "*?[") else p in key
               for p in patterns)


def _row(key: str, ci: dict, width: int) -> str:
    line = f"  {key:<{width}} {ci['mean']:.4g}  [{ci['low']:.4g}, {ci['high']:.4g}]{_flags(ci)}"
    if len(line) <= WIDTH:
        return line
    return f"  {key}\n  {'':<{min(width, 40)}} {line[2 + width + 1:].strip()}"


def _cmd_show(args) -> int:
    from qdensity_paper.results import ExperimentResult

    result = ExperimentResult.load(args.file)
    summary = result.summary
    if args.metric:
        summary = {k: v for k, v in summary.items() if _matches(k, args.metric)}
        if not summary:
            raise ValueError(f"--metric {' '.join(args.metric)!r} matches none of the "
                             f"{len(result.summary)} metrics of {args.file!r}, e.g. "
                             f"{', '.join(list(result.summary)[:4])}")
    if _json(args):
        print(json.dumps({"name": result.name, "mode": result.mode, "seeds": result.seeds,
                          "config": result.config, "summary": summary}, indent=2))
        return 0
    print(f"{result.name} ({result.mode}, seeds {result.seeds})")
    print_summary(summary)
    return 0


def print_summary(summary: dict) -> None:
    """Mean and 95% CI per metric: the headline metrics first, then counts and sizes; lines
    within :data:`WIDTH`."""
    head = {k: v for k, v in summary.items() if is_headline(k)}
    rest = {k: v for k, v in summary.items() if k not in head}
    width = min(max((len(k) for k in summary), default=0), 50)
    for title, part in (("headline metrics", head), ("counts and sizes", rest)):
        if part:
            print(f"{title}:")
            for key, ci in part.items():
                print(_row(key, ci, width))


def _cmd_merge(args) -> int:
    from qdensity_paper.merge import merge_results
    from qdensity_paper.results import ExperimentResult

    merged = merge_results([ExperimentResult.load(p) for p in args.files])
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, json.dumps(merged.to_dict(), indent=2) + "\n")
    if _json(args):
        print(json.dumps(merged.to_dict(), indent=2))
    else:
        print(f"merged {len(args.files)} files: {merged.name} ({merged.mode}), seeds "
              f"{merged.seeds} -> {out}")
    return 0


QUICK = "quick run: not judged"


def _label(path: Path, root: Path) -> str:
    """A results file's name in the report: its path under the results folder."""
    return path.relative_to(root).as_posix()


def _judged(paths: list[Path], rows: list[dict], root: Path) -> list[dict]:
    """The rule's verdict rows, plus one row saying :data:`QUICK` for each quick run (the rule
    judges none: a quick run's few seeds and small settings are not the paper's protocol)."""
    from qdensity_paper.results import ExperimentResult

    judged = {r["file"] for r in rows}
    quick = [{"file": _label(p, root), "mode": "quick", "verdict": QUICK} for p in paths
             if _label(p, root) not in judged and ExperimentResult.load(p).mode == "quick"]
    return [r for r in rows if r.get("mode") != "quick"] + quick


def _print_report(paths: list[Path], rows: list[dict], root: Path) -> None:
    """The verdicts as wrapped text, one block per results file, within :data:`WIDTH`."""
    from qdensity_paper.results import ExperimentResult
    from qdensity_paper.verdicts import format_estimate, looks_text

    for path in paths:
        mine = [r for r in rows if r["file"] == _label(path, root)]
        mode = mine[0]["mode"] if mine else ExperimentResult.load(path).mode
        print(f"{_label(path, root)} ({mode})")
        if not mine:
            print("  no claim of the paper to judge in this file")
        for row in mine:
            if row["verdict"] == QUICK:
                print(f"  {QUICK}")
                continue
            ci = format_estimate(row)
            print(textwrap.fill(f"{row['verdict']}: {row['claim']}", WIDTH, initial_indent="  ",
                                subsequent_indent="    "))
            caveat = f"caveat: {row['caveat']}" if row.get("caveat") else ""
            detail = "; ".join(t for t in (f"{row['quantity']} = {ci}" if ci else row["quantity"],
                                           looks_text(row), row.get("reason", ""), caveat) if t)
            print(textwrap.fill(detail, WIDTH, initial_indent="    ",
                                subsequent_indent="    "))


def _cmd_report(args) -> int:
    from qdensity_paper.results import ExperimentResult
    from qdensity_paper.verdicts import evaluate, report, results_paths, splice

    directory = Path(args.dir)
    if not directory.is_dir():
        raise ValueError(f"--dir {args.dir!r} is not a folder (it holds the results files, "
                         "NAME-MODE.json, that qdensity experiment --out writes)")
    paths = results_paths(directory)
    if not (args.write or args.check):
        rows = _judged(paths, evaluate(paths, directory), directory)
        if _json(args):
            print(json.dumps(rows, indent=2))
        elif not paths:
            print(f"no results files (*.json) in {str(directory)!r}")
        else:
            _print_report(paths, rows, directory)
        return 0
    docs = Path(args.docs)
    missing = [n for n in ("README.md", "EXPERIMENTS.md") if not (docs / n).is_file()]
    if missing:
        raise ValueError(f"--write and --check update README.md and EXPERIMENTS.md in --docs "
                         f"{str(docs)!r}, but {' and '.join(missing)} "
                         f"{'is' if len(missing) == 1 else 'are'} not there; without "
                         "--write or --check the report is only printed")
    quick = [p.name for p in paths if ExperimentResult.load(p).mode == "quick"]
    if quick:
        raise ValueError(f"{', '.join(quick)} in {str(directory)!r} are quick runs, which are "
                         "not judged against the paper; move them out before --write/--check")
    generated = report(directory)
    if _json(args):
        print(json.dumps(evaluate(paths, directory), indent=2))
    drift = []
    for name, text in generated.items():
        path = docs / name
        current = path.read_text(encoding="utf-8")
        updated = splice(current, text, str(path))
        if args.write and updated != current:
            atomic_write_text(path, updated)
            print(f"wrote {path}")
        elif args.check and updated != current:
            drift.append(str(path))
    if drift:
        raise ValueError(f"{', '.join(drift)} differ from the report of {str(directory)!r}: run "
                         "qdensity results report --write")
    return 0


def add_parser(sub) -> None:
    """Add the ``results`` sub-command group to ``qdensity``'s sub-parsers."""
    r = sub.add_parser("results", help="show, merge and judge experiment results files",
                       **texts("results"))
    r.add_argument("--json", action="store_true",
                   help="print JSON (the same as the sub-command's --json)")
    r.set_defaults(func=_cmd_none)
    rs = r.add_subparsers(dest="results_command", metavar="{show,merge,report}",
                          help="show: a file's summary; merge: files into one; report: verdicts")
    show = rs.add_parser("show", help="print a results file's summary table",
                         **texts("results show"))
    show.add_argument("file", help="a results JSON (NAME-MODE.json)")
    show.add_argument("--metric", action="append", default=[], metavar="PATTERN",
                      help="only metrics whose name matches PATTERN: a shell pattern (with * and ? "
                           "as wildcards) or a part of the name ('accuracy'); repeatable")
    show.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                      help="print the summary as JSON")
    show.set_defaults(func=_cmd_show)
    merge = rs.add_parser("merge", help="merge runs of one experiment, mode and settings",
                          **texts("results merge"))
    merge.add_argument("files", nargs="+", help="results JSON files")
    merge.add_argument("-o", "--output", required=True, help="the merged file to write")
    merge.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                       help="also print the merged JSON")
    merge.set_defaults(func=_cmd_merge)
    rep = rs.add_parser("report", help="verdicts by rule from the results files; --write puts "
                                       "them into README.md and EXPERIMENTS.md",
                        **texts("results report"))
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
