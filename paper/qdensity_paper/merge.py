"""Merging results files of one experiment run in pieces (``qdensity results merge``).

Seeds of one experiment may run on different machines or at different times; their files merge
into one when they ran the same experiment, mode and settings. Seeds must be disjoint, or, where
a seed appears twice, its metrics must be identical (the same seed gives the same numbers; its
wall time and the worker it ran on may differ). The
summary and the curves are recomputed over the merged seeds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from qdensity_paper._result_files import check_fields
from qdensity_paper.results import ExperimentResult, curve_summary, summarise

__all__ = ["merge_results", "first_difference"]

#: Per-seed entries that say where and how long a seed ran, not what it gave: two runs of a
#: seed that differ only in these are the same run.
_WHERE_AND_HOW_LONG = frozenset({"seconds", "worker"})


def first_difference(a, b, path: str = "") -> str | None:
    """The path of the first place where two JSON-like values differ, or None.

    Examples
    --------
    >>> first_difference({"x": 1, "y": [1, 2]}, {"x": 1, "y": [1, 3]})
    'y[1]'
    """
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b), key=str):
            where = f"{path}.{key}" if path else str(key)
            if key not in a or key not in b:
                return where
            found = first_difference(a[key], b[key], where)
            if found is not None:
                return found
        return None
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return f"{path} (length {len(a)} vs {len(b)})"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            found = first_difference(x, y, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return None
    return None if a == b else (path or "value")


def merge_results(results: Sequence[ExperimentResult]) -> ExperimentResult:
    """One result holding the seeds of several runs of the same experiment, mode and settings.

    Parameters
    ----------
    results : sequence of ExperimentResult, length >= 1

    Returns
    -------
    ExperimentResult
        Seeds sorted, per-seed metrics of each seed once, summary and curves recomputed,
        ``seconds`` the sum of the runs' wall times, versions of the first run; ``looks`` the
        first run's (or its seeds) and, when the merge adds seeds, the merged seeds after them.

    Raises
    ------
    ValueError
        No results; results of different experiments, modes or settings (the message names the
        first differing field); a seed in two runs with different metrics (named with the
        first differing metric).
    TypeError
        An element that is not an :class:`ExperimentResult`.
    """
    results = list(results)
    if not results:
        raise ValueError("results is empty: give at least one results file to merge")
    for i, r in enumerate(results):
        if not isinstance(r, ExperimentResult):
            raise TypeError(f"results[{i}] must be an ExperimentResult, got {type(r).__name__}")
        check_fields(r.__dict__, f"results[{i}]")  # seeds changed after construction too
    first = results[0]
    for i, r in enumerate(results[1:], start=1):
        for field in ("name", "mode"):
            if getattr(r, field) != getattr(first, field):
                raise ValueError(f"results[{i}] has {field} {getattr(r, field)!r}, results[0] "
                                 f"{getattr(first, field)!r}: only runs of one experiment and "
                                 "mode merge")
        where = first_difference(first.config, r.config)
        if where is not None:
            raise ValueError(f"results[{i}] ran other settings than results[0]: first "
                             f"difference at config.{where}")
    by_seed: dict[int, dict] = {}
    for i, r in enumerate(results):
        for seed, row in zip(r.seeds, r.per_seed, strict=True):
            if seed in by_seed:
                where = first_difference({k: v for k, v in by_seed[seed].items()
                                          if k not in _WHERE_AND_HOW_LONG},
                                         {k: v for k, v in row.items()
                                          if k not in _WHERE_AND_HOW_LONG})
                if where is not None:
                    raise ValueError(f"seed {seed} is in two runs with different results "
                                     f"(first difference at {where}, results[{i}]); the same "
                                     "seed must give the same numbers")
                continue
            by_seed[seed] = row
    seeds = sorted(by_seed)
    per_seed = [by_seed[s] for s in seeds]
    seconds = [r.seconds for r in results if r.seconds is not None]
    looks = [list(look) for look in first.looks] or [sorted(first.seeds)][:len(first.seeds)]
    if not looks or set(seeds) != set(looks[-1]):  # the merged seeds are one more look
        looks.append(seeds)
    merged = ExperimentResult(name=first.name, mode=first.mode, config=dict(first.config),
                              seeds=seeds, per_seed=per_seed, looks=looks,
                              summary=summarise(per_seed),
                              curves=curve_summary(per_seed),
                              figures=[], seconds=sum(seconds) if seconds else None,
                              versions=dict(first.versions))
    return merged
