"""What every ``qdensity`` sub-command's ``--help`` says above and below its options: a
description and worked examples, kept in one table so that they read alike.

:func:`texts` gives the keyword arguments of ``add_parser`` (``description``, ``epilog``);
:class:`Formatter` keeps their line breaks and shows the options' defaults.
"""

from __future__ import annotations

import argparse

from qdensity.cli.plugins import CommandTexts, command_texts

__all__ = ["Formatter", "texts", "HELP"]


class Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Descriptions and examples as written (line breaks kept); options with their defaults."""


#: ``command path -> (description, examples)``; a path is ``"build"`` or ``"results show"``.
HELP: dict[str, tuple[str, str]] = {
    "build": (
        "Build one of the named circuits (loaders, Hamming-weight-preserving ansatze, density\n"
        "circuits of Fig. 1), print its size and draw it, or export it as OpenQASM 3 (or 2).",
        "qdensity build pyramid --size 6\n"
        "qdensity build round_robin --size 4 --unbound --qasm rr4.qasm\n"
        "qdensity build pyramid --qasm - --qasm-version 2   # OpenQASM 2 on stdout",
    ),
    "transpile": (
        "Transpile a named circuit for a target (a named device family, a saved calibration\n"
        "snapshot or a fake backend) and print its resource report: two-qubit gates, depth,\n"
        "layout and the estimated fidelity.",
        "qdensity transpile pyramid --size 8 --target heavy_hex\n"
        "qdensity transpile butterfly --size 8 --target ideal --optimization-level 3 --json",
    ),
    "run": (
        "Estimate a round-robin density model's output f(x) (eq. 3) on a noisy simulated\n"
        "target from a shot budget split over the sub-unitaries by a scheduler (Supp. I),\n"
        "optionally with readout mitigation and Hamming-weight post-selection.",
        "qdensity run --size 6 --shots 4000 --scheduler neyman\n"
        "qdensity run --target fake_manila --size 4 --mitigation m3 --json",
    ),
    "table1": (
        "Rebuild the paper's Table 1 (gradient circuits per ansatz) by counting the circuits\n"
        "of real gradient plans.",
        "qdensity table1\n"
        "qdensity table1 --n 4 8 16 --ansatz pyramid butterfly --json",
    ),
    "export": (
        "Write the reference circuits (OpenQASM 2 and 3, with a README index) into a folder,\n"
        "or check that a folder's files are current.",
        "qdensity export circuits\n"
        "qdensity export circuits --check\n"
        "qdensity export my-circuits --qasm3",
    ),
    "demo": (
        "Train a round-robin OrthoQNN and its density version on digits with sampled\n"
        "gradients on a noisy heavy-hex device at the same shot budget, beside each model's\n"
        "exact-training ceiling; prints a table and writes a figure.",
        "qdensity demo --quick\n"
        "qdensity demo --budget 200000 --output figures --json",
    ),
    "sweep": (
        "Optuna hyperparameter sweep of a QNNClassifier over the paper's search space\n"
        "(hyperparameters appendix). Workers started with one --storage share a study.",
        "qdensity sweep --dataset digits --n-trials 16\n"
        "qdensity sweep --storage sqlite:///shared.db --study digits-rr --export trials.csv",
    ),
}


def texts(command: str) -> CommandTexts:
    """``description=`` and ``epilog=`` (``examples:`` and the example lines) for
    ``add_parser``."""
    return command_texts(*HELP[command])
