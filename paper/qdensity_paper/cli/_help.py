"""What ``qdensity experiment`` and ``qdensity results`` say in ``--help`` above and below their
options: a description and worked examples per command path."""

from __future__ import annotations

from qdensity.cli.plugins import CommandTexts, command_texts

__all__ = ["HELP", "texts"]

#: ``command path -> (description, examples)``; a path is ``"experiment"`` or ``"results show"``.
HELP: dict[str, tuple[str, str]] = {
    "experiment": (
        "Run one of the paper's experiments (a figure or a section of the paper, see\n"
        "--list) over seeds; print the metrics with 95% confidence intervals and, with --out,\n"
        "write NAME-MODE.json and the figures.",
        "qdensity experiment --list\n"
        "qdensity experiment mixing-lemma --quick\n"
        "qdensity experiment orthoqnn-depth --full --seeds 5 --out my-results",
    ),
    "results": (
        "Read, merge and judge experiment results files in any folder.",
        "qdensity results show my-results/mixing-lemma-quick.json --metric accuracy\n"
        "qdensity results merge a.json b.json -o merged.json\n"
        "qdensity results report --dir my-results",
    ),
    "results show": (
        "Print a results file's summary: the headline metrics (accuracies, losses, errors)\n"
        "first, then the rest (circuit and shot counts); mean and 95% CI per metric.",
        "qdensity results show results/orthoqnn-depth-full.json\n"
        "qdensity results show my-results/noise-quick.json --metric 'test_*' --json",
    ),
    "results merge": (
        "Merge runs of one experiment, mode and settings (e.g. seeds run on other machines)\n"
        "into one results file.",
        "qdensity results merge run-a/moe-full.json run-b/moe-full.json -o moe-full.json",
    ),
    "results report": (
        "Judge the paper's claims by a written rule from the results files of a folder and\n"
        "print the verdicts. Quick runs are not judged. Only --write and --check read\n"
        "README.md and EXPERIMENTS.md (in --docs), between their markers.",
        "qdensity results report --dir my-results\n"
        "qdensity results report --dir results --write   # in the qdensity repository",
    ),
}


def texts(command: str) -> CommandTexts:
    """``description=`` and ``epilog=`` for ``add_parser``
    (:func:`qdensity.cli.plugins.command_texts`)."""
    return command_texts(*HELP[command])
