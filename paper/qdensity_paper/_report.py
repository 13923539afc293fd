"""The text of ``qdensity results report``: the README's table and EXPERIMENTS.md's verdicts
(:func:`report`), and the headline verdict of each counted claim (:func:`headline`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from qdensity_paper.claims import CLAIMS, counted
from qdensity_paper.results import ExperimentResult, runs_above
from qdensity_paper.verdicts import (
    DECIDED,
    VERDICTS,
    _detail,
    evaluate,
    format_estimate,
    looks_text,
    results_paths,
)

__all__ = ["headline", "report"]


_RULE = ("Rule (`qdensity_paper.verdicts`): each claim declares its kind and is judged by "
         "the test that fits, at level 0.05 spent over its looks. **superiority** and "
         "**trend** (the per-seed slope over the grid): the two-sided Student-t interval at the "
         "look's level excludes 0 on the paper's side (**reproduced**) or on the other (**not "
         "reproduced**). **monotone** (\"increases monotonically\"): every step between "
         "neighbouring grid points judged as a superiority claim; reproduced only when every "
         "step is. **composite** (a sentence with several parts): reproduced only when every "
         "part is, not reproduced when any part is not (an intersection-union test: no "
         "multiplicity correction is needed). **non-inferiority** (\"minimal or no loss\"): a "
         "one-sided t-test at the stated margin (**non-inferior**; the interval below minus "
         "the margin: **not reproduced**). **equivalence**: two one-sided tests (TOST) at the "
         "margin (**equivalent**; the interval outside it: **not reproduced**). **bound** (a "
         "theorem): its margin is >= 0 in every seed, the smallest reported; **exact**: a "
         "count, equal in every seed. Otherwise **inconclusive**, with the fresh seeds a "
         "confirmatory run would need for 80% power at 0.05. **not comparable**: a departure "
         "from the paper touches the claim (the protocol's listed departures, a setting "
         "outside the paper's readings, or a `--full` run, a reduced protocol). `--quick` runs "
         "are never judged.\n\n"
         "**Sequential looks.** Seeds were added to some runs after an inconclusive look. "
         "Every results file records its looks (`looks`: the seed sets judged, in order, "
         "recovered from the history of `results/`), and each claim's alpha of 0.05 is spent "
         "over them by the Lan-DeMets O'Brien-Fleming function of the information fraction "
         "`n / n_max` (`n_max`: the claim's declared largest seed count, "
         "`qdensity_paper.claims.MAX_SEEDS`); each look is judged at the alpha it spends, so by "
         "the Bonferroni inequality the chance of a false decision over all looks stays at or "
         "under 0.05. A claim stops at the first look that decides it. The sequential stage is "
         "closed at the seeds each file holds: a claim still undecided can be decided only by "
         "a confirmatory run on fresh seeds alone, at 0.05. \"added seeds alone\" reports the "
         "seeds added after the first look, judged on their own at the last look's level.\n\n"
         "**Categories.** `paper`: an experimental statement of the paper, quoting its words "
         "verbatim; `extension`: ours (dropout numerics, a reading of a plot that no sentence "
         "states); `structural`: a property of the construction or a theorem, checked by a "
         "test. The headline counts `paper` claims only; a composite's parts and a second "
         "reading reported beside a claim are not counted on their own.")


def headline(rows: Sequence[dict]) -> dict[str, str]:
    """Each counted claim's verdict over the runs that judge it at the paper's protocol
    (``paper`` runs; ``full`` runs that are comparable where no ``paper`` run judges it): not
    reproduced in any run ->
    ``not reproduced``; decided on the paper's side in every run -> that verdict; otherwise
    ``inconclusive``; no comparable run -> ``not comparable``."""
    out = {}
    for c in CLAIMS:
        if not counted(c):
            continue
        judged = [r for r in rows if r["key"] == c.key and r["verdict"] != "not comparable"]
        mine = ([r["verdict"] for r in judged if r["mode"] == "paper"]
                or [r["verdict"] for r in judged if r["mode"] == "full"])
        if not mine:
            out[c.key] = "not comparable"
        elif "not reproduced" in mine:
            out[c.key] = "not reproduced"
        elif all(v in DECIDED for v in mine):
            out[c.key] = mine[0] if len(set(mine)) == 1 else "reproduced"
        else:
            out[c.key] = "inconclusive"
    return out


def report(directory: str | Path) -> dict[str, str]:
    """The generated text: ``{"README.md": table, "EXPERIMENTS.md": verdicts}``.

    Parameters
    ----------
    directory : path
        Holds the results files (``NAME-MODE.json``; other readings in sub-folders).

    Returns
    -------
    dict
        File name -> the Markdown to place between :data:`MARKERS`.
    """
    root = Path(directory)
    paths = results_paths(root)
    rows = evaluate(paths, root)
    names = [p.relative_to(root).as_posix() for p in paths]
    table = ["| experiment | run | claims judged | verdicts by rule |", "|---|---|---|---|"]
    for name in names:
        mine = [r for r in rows if r["file"] == name]
        if not mine:
            continue
        counts = [f"{sum(r['verdict'] == v for r in mine)} {v}" for v in VERDICTS
                  if any(r["verdict"] == v for r in mine)]
        table.append(f"| `{mine[0]['experiment']}` | `{name}` | {len(mine)} | "
                     f"{', '.join(counts)} |")
    heads = headline(rows)
    decided = sorted(k for k, v in heads.items() if v in DECIDED)
    positive = sorted(k for k, v in heads.items() if v in DECIDED and v != "not reproduced")
    summary = (f"{len(decided)} of the paper's {len(heads)} experimental claims decided at its "
               f"protocol ({len(positive)} reproduced, non-inferior or equivalent; "
               f"{len(decided) - len(positive)} not reproduced), each at its level corrected "
               "for the looks taken")
    readme = "\n".join(["Verdicts by a written rule (EXPERIMENTS.md, 'Verdicts by rule'), "
                         f"computed from the files in `results/`: {summary}.", "", *table])
    lines = [_RULE, "", f"**{summary}.**", "",
             "| the paper's claim | verdict over its runs | looks, the deciding look and the "
             "alpha spent (each judged run) |", "|---|---|---|"]
    by_key = {c.key: c for c in CLAIMS}
    for k, v in heads.items():
        judged = [f"`{r['file']}`: {looks_text(r)}" for r in rows
                  if r["key"] == k and r["verdict"] != "not comparable" and "looks" in r]
        lines.append(f"| {by_key[k].text} (`{k}`) | **{v}** | {'; '.join(judged)} |")
    pocock = {(r["file"], r["key"]): r["verdict"] for r in evaluate(paths, root,
                                                                    spending="pocock")}
    moved = [f"`{r['key']}` in `{r['file']}` ({r['verdict']} -> "
             f"{pocock[(r['file'], r['key'])]})" for r in rows
             if pocock[(r["file"], r["key"])] != r["verdict"]]
    lines += ["", "With Pocock's spending function instead of O'Brien-Fleming's: "
              + ("; ".join(moved) if moved else "no verdict changes") + ".", "",
              "| run | claim | category | kind | quantity (per seed) | estimate [interval] | "
              "verdict | looks | why / what would resolve it |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        role = (f" (part of `{r['part_of']}`)" if r.get("part_of") else
                f" (beside `{r['beside']}`)" if r.get("beside") else "")
        lines.append(f"| `{r['file']}` | {r['claim']}{role} | {r['category']} | {r['kind']} | "
                     f"`{r['quantity']}` | {format_estimate(r)} | **{r['verdict']}** | "
                     f"{looks_text(r)} | {_detail(r)} |")
    judged = {r["key"] for r in rows}
    lines += ["", "Every claim, with the paper's words and margins (claims no results file "
              "answers yet are marked *no run*):", "",
              "| claim | category | kind | the paper's words | margins | seeds at most | "
              "judged in |", "|---|---|---|---|---|---|---|"]
    for c in CLAIMS:
        files = ", ".join(f"`{r['file']}`" for r in rows if r["key"] == c.key) or "*no run*"
        margins = (f"{c.margins[0]:g} / {c.margins[1]:g} ({c.margin_reason})" if c.margins
                   else "")
        n_max = c.n_max if c.kind not in ("bound", "exact") else ""
        lines.append(f"| {c.text} (`{c.key}`) | {c.category} | {c.kind} | {c.quoted} | "
                     f"{margins} | {n_max} | {files if c.key in judged else '*no run*'} |")
    lines += ["", "Every departure of the `--paper` protocols from the paper, and the claims "
              "it touches (those read *not comparable* where a run has it):", "",
              "| experiment | departure | claims touched |", "|---|---|---|"]
    lines += _departure_table()
    sweeps = _sweep_table(paths)
    if sweeps:
        lines += ["", "The paper's sweep aggregation (hyperparameters appendix): trials that "
                  "reach 80% test accuracy, out of each seed's study, and their mean.", "",
                  "| run | model | trials >= 0.8 per seed | mean of those |", "|---|---|---|---|",
                  *sweeps]
    return {"README.md": readme, "EXPERIMENTS.md": "\n".join(lines)}


def _departure_table() -> list[str]:
    from qdensity_paper.registry import EXPERIMENTS, get_experiment

    lines = []
    for name in EXPERIMENTS:
        protocol = get_experiment(name).protocol
        for d in () if protocol is None else protocol.departures:
            touched = ("every claim" if "*" in d.touches else
                       ", ".join(f"`{k}`" for k in d.touches) or "none")
            if d.applies is not None:
                touched += " (in the runs that have it)"
            lines.append(f"| `{name}` | {d.text} | {touched} |")
    return lines


def _sweep_table(paths) -> list[str]:
    lines = []
    for path in paths:
        result = ExperimentResult.load(path)
        models = sorted({k[: -len("/trials")] for row in result.per_seed
                         for k in row.get("curves", {}) if k.endswith("/trials")})
        for m in models:
            per = [runs_above(row["curves"][f"{m}/trials"]["y"]) for row in result.per_seed
                   if f"{m}/trials" in row.get("curves", {})]
            counts = ", ".join(f"{a['count']}/{a['of']}" for a in per)
            kept = [v for row in result.per_seed for v in row["curves"].get(f"{m}/trials",
                                                                              {}).get("y", [])
                    if v >= 0.8]
            mean = f"{np.mean(kept):.3f}" if kept else "none"
            lines.append(f"| `{path.name}` | {m} | {counts} | {mean} |")
    return lines


