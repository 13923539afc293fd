"""``qdensity experiment NAME``: the paper's experiments (:func:`qdensity_paper.run`)."""

from __future__ import annotations

import argparse
import json

from qdensity_paper.cli._help import texts
from qdensity_paper.cli.results import print_summary

__all__ = ["add_parser"]


def _setting(text: str) -> tuple[str, object]:
    """An argparse ``type``: ``KEY=VALUE`` with VALUE read as JSON (else kept as text)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key, json.loads(value)
    except json.JSONDecodeError:
        return key, value


def _seeds(text: str) -> list[int] | int:
    """An argparse ``type``: a count (``5``) or a comma-separated list (``0,3,7``)."""
    try:
        values = [int(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a count or a list like 0,1,2, got "
                                         f"{text!r}") from None
    return values[0] if "," not in text else values


def _listing(rows: list[dict], width: int = 100) -> str:
    """The experiments by the part of the paper they reproduce (figure, section), then what
    they compare; wrapped to ``width`` columns."""
    import textwrap

    out = []
    for row in rows:
        pad = " " * 17
        out.append(textwrap.fill(row["paper"], width, initial_indent=f"{row['name']:<15}  ",
                                 subsequent_indent=pad))
        out.append(textwrap.fill(row["title"], width, initial_indent=pad + "compares: ",
                                 subsequent_indent=pad + "  "))
    return "\n".join(out)


def _cmd_experiment(args) -> int:
    from qdensity_paper.registry import EXPERIMENTS, get_experiment, run

    if args.list:
        rows = []
        for name in EXPERIMENTS:
            exp = get_experiment(name)
            rows.append({"name": name, "title": exp.title, "paper": exp.paper})
        if args.json:
            print(json.dumps(rows, indent=2))
        else:
            print(_listing(rows))
        return 0
    if args.name is None:
        raise ValueError(f"name an experiment (one of: {', '.join(EXPERIMENTS)}) or --list")
    mode = "paper" if args.paper else "full" if args.full else "quick"
    result = run(args.name, mode=mode, seeds=args.seeds, config=dict(args.set) or None,
                 out=args.out, jobs=args.jobs, cluster=args.cluster, plot=not args.no_plot,
                 progress=True)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
        return 0
    print(f"{args.name} ({mode}, seeds {result.seeds}, {result.seconds:.0f} s)")
    print_summary(result.summary)
    if args.out is not None:
        saved = result.saved_to  # this run's own file (another run's settings: a named one)
        print(f"results: {saved if saved is not None else f'{args.out}/{args.name}-{mode}.json'}")
        for name in result.figures:
            print(f"figure: {args.out}/{name}")
    return 0


def add_parser(sub) -> None:
    """Add the ``experiment`` sub-command to ``qdensity``'s sub-parsers."""
    from qdensity_paper.registry import EXPERIMENTS

    x = sub.add_parser("experiment", help="run one of the paper's experiments over seeds: "
                                          "results JSON with 95%% confidence intervals and "
                                          "figures", **texts("experiment"))
    x.add_argument("name", nargs="?", help=f"one of: {', '.join(EXPERIMENTS)}%(default).0s")
    size = x.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true",
                      help="small settings, at most a minute on two cores (the default)")
    size.add_argument("--full", action="store_true",
                      help="the paper's protocol as far as two cores allow (see EXPERIMENTS.md "
                           "for each experiment's reductions)")
    size.add_argument("--paper", action="store_true",
                      help="the paper's own settings where it states them (both readings where "
                           "it is ambiguous); --set may not change a setting the paper fixes")
    x.add_argument("--seeds", type=_seeds, default=None,
                   help="number of seeds (runs 0..S-1) or a list like 0,3,7 (default: 2 for "
                        "--quick, 5 for --full)%(default).0s")
    x.add_argument("--out", default=None, metavar="DIR",
                   help="write DIR/NAME-MODE.json and the PNG figures there (default: nothing "
                        "written)%(default).0s")
    x.add_argument("--jobs", type=int, default=1,
                   help="run units (a seed, or a setting of a seed) in this many local worker "
                        "processes at once (the same as --cluster local:N)")
    x.add_argument("--cluster", default=None, metavar="ADDRESS",
                   help="run the units on Dask: 'local' (a worker process per core), 'local:N' "
                        "(N worker processes) or 'tcp://HOST:PORT' (a running 'dask scheduler' "
                        "with 'dask worker' processes on any machines; --out then on a shared "
                        "file system). Finished units are written under --out as they arrive; "
                        "rerunning the command resumes; a unit whose worker is lost runs again")
    x.add_argument("--set", type=_setting, action="append", default=[], metavar="KEY=VALUE",
                   help="override one setting (VALUE read as JSON), e.g. --set epochs=3")
    x.add_argument("--no-plot", action="store_true", help="do not draw the figures")
    x.add_argument("--list", action="store_true", help="list the experiments and exit")
    x.add_argument("--json", action="store_true",
                   help="print the results JSON (what ExperimentResult.to_dict gives) instead "
                        "of the summary")
    x.set_defaults(func=_cmd_experiment)
