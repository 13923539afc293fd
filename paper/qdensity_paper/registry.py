"""The paper's experiments by name: ``qdensity_paper.run(name, ...)`` and
``qdensity experiment NAME``.

Each experiment is a module of this package that defines ``EXPERIMENT``, an
:class:`Experiment`: its settings at two sizes (``quick``: at most a minute on two cores, what
the tests and notebooks run; ``full``: the paper's protocol as far as two cores allow, reduced
where its docstring says), a function that runs one seed and returns that seed's metrics, and
a function that draws the figure. :func:`run` runs the units of work (one seed, or one
setting of one seed where the experiment splits its settings with ``units``), one after another
in this process or on a Dask cluster (:mod:`qdensity.cluster`: ``jobs`` local worker processes,
or ``cluster``), writes each finished unit under ``out`` as it arrives (a rerun resumes), writes
the results JSON (:class:`~.results.ExperimentResult`: settings, seeds, per-seed metrics with
the worker that ran them, mean and 95% confidence interval over seeds, package versions) and the
PNG figures, and returns the result.

Metrics of one seed are a flat dict of scalars (``"density/test_accuracy": 0.81``) plus an
optional ``"curves"`` dict: curve name -> ``{"x": [...], "y": [...], "x_label": ...,
"y_label": ...}`` (test accuracy against epochs or shots). :func:`run` summarises the scalars
with :func:`~.results.mean_ci` and each curve point by point with :func:`curve_summary`.
"""

from __future__ import annotations

import importlib
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from qdensity.cluster import IN_PROCESS, open_client, run_units
from qdensity.progress import progress_bar
from qdensity.validation import (
    MAX_SEEDS,
    CallableC,
    FilePath,
    Instance,
    Interval,
    Options,
    SequenceOf,
    Unchecked,
    validates,
)
from qdensity_paper import _units
from qdensity_paper.protocol import check_overrides, resolve_paper
from qdensity_paper.results import ExperimentResult, curve_summary

__all__ = ["Experiment", "EXPERIMENTS", "MODES", "get_experiment", "run", "curve_summary",
           "resolve_seeds", "resolve_config", "work_directory"]

work_directory = _units.work_directory

#: Experiment name -> module of :mod:`qdensity_paper` that defines ``EXPERIMENT``.
EXPERIMENTS: dict[str, str] = {
    "equivariant": "equivariant",
    "orthoqnn-depth": "orthoqnn_depth",
    "pyramid-shots": "pyramid_shots",
    "moe": "moe",
    "reuploading": "reuploading",
    "lcu-vs-single": "lcu_vs_single",
    "mixing-lemma": "mixing_lemma",
    "dropout": "dropout",
    "noise": "noise",
    "absolute-gap": "absolute_gap",
}

#: Sizes every experiment offers.
MODES = ("quick", "full", "paper")


@validates(
    name=Instance(str), title=Instance(str), paper=Instance(str), quick=Instance(Mapping),
    full=Instance(Mapping), run_seed=CallableC('a callable (config, seed, verbose) -> metrics'),
    plot=CallableC('a callable (result, folder) -> paths'), seeds=Instance(Mapping),
    reductions=Instance(str), units=[CallableC('a callable config -> unit configs'), None],
    combine=[CallableC('a callable (config, unit metrics) -> metrics'), None],
    protocol=Unchecked('the experiment protocol, any object'),
)
@dataclass(frozen=True)
class Experiment:
    """One of the paper's experiments.

    Attributes
    ----------
    name : str
        The name ``qdensity experiment`` takes (a key of :data:`EXPERIMENTS`).
    title : str
        One line: what is compared.
    paper : str
        Where the paper reports it (figure, section, appendix).
    quick, full : dict
        Settings at each size; every key may be overridden through ``run(config=...)``.
    seeds : dict
        Default number of seeds per mode, e.g. ``{"quick": 2, "full": 5}``.
    run_seed : callable
        ``run_seed(config, seed, progress) -> dict``: one seed's metrics (scalars and an
        optional ``"curves"`` dict, see the module docstring). Must be a module-level function
        (it runs on Dask workers when ``jobs > 1`` or with a ``cluster``).
    plot : callable
        ``plot(result, directory) -> list[Path]``: writes the PNG figures.
    reductions : str
        Where ``full`` departs from the paper's protocol, and why (also printed in
        ``EXPERIMENTS.md``).
    units : callable, optional
        ``units(config) -> list[dict]``: the seed's work split into independent settings (one
        sub-configuration per model or depth), each a unit of work that ``run_seed`` runs on
        its own; the seed's metrics are the units' merged (:func:`~._units.merge_parts`), or
        ``combine(config, parts)``. A unit must give the metrics it gives inside the whole
        seed, bit for bit (its randomness may not depend on the units run before it).
        Module-level functions. None: the seed is one unit.
    combine : callable, optional
        ``combine(config, parts) -> dict``: a seed's metrics from its units' (default: merged).
    """

    name: str
    title: str
    paper: str
    quick: Mapping[str, Any]
    full: Mapping[str, Any]
    run_seed: Callable[[dict, int, bool], dict]
    plot: Callable[[ExperimentResult, Path], list[Path]]
    seeds: Mapping[str, int] = field(default_factory=lambda: {"quick": 2, "full": 5})
    reductions: str = ""
    units: Callable[[dict], list[dict]] | None = None
    combine: Callable[[dict, list[dict]], dict] | None = None
    protocol: Any = None  # qdensity_paper.protocol.PaperProtocol: the --paper settings


@validates(name=Instance(str))
def get_experiment(name: str) -> Experiment:
    """The :class:`Experiment` called ``name``.

    Raises
    ------
    ValueError
        For an unknown name; the message lists the known ones.
    """
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; known: {', '.join(EXPERIMENTS)}")
    module = importlib.import_module(f"qdensity_paper.{EXPERIMENTS[name]}")
    return module.EXPERIMENT


def resolve_seeds(seeds, default: int) -> list[int]:
    """Seeds to run: ``None`` -> ``range(default)``, an int ``S`` -> ``range(S)``, a sequence
    of distinct non-negative ints -> itself.

    Raises
    ------
    ValueError, TypeError
        For a non-positive count, negative or repeated seeds, or non-integers.
    """
    if seeds is None:
        return list(range(default))
    if isinstance(seeds, bool):
        raise TypeError(f"seeds must be an int or a sequence of ints, got {seeds!r}")
    if isinstance(seeds, (int, np.integer)):
        if seeds < 1:
            raise ValueError(f"seeds must be at least 1 (a number of seeds), got {seeds}")
        return list(range(int(seeds)))
    if not isinstance(seeds, Sequence) or isinstance(seeds, str):
        raise TypeError(f"seeds must be an int or a sequence of ints, got {seeds!r}")
    out = []
    for s in seeds:
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)):
            raise TypeError(f"seeds must hold ints, got {s!r}")
        if s < 0:
            raise ValueError(f"seeds must be non-negative, got {s}")
        out.append(int(s))
    if not out:
        raise ValueError("seeds is empty: give at least one seed")
    if len(set(out)) != len(out):
        raise ValueError(f"seeds must be distinct, got {out}")
    return out


def resolve_config(experiment: Experiment, mode: str, config: Mapping | None) -> dict:
    """The settings of ``mode`` with ``config``'s overrides; unknown keys are refused."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if mode == "paper":
        return resolve_paper(experiment.name, experiment.protocol, config)
    base = dict(getattr(experiment, mode))
    if config is None:
        return base
    check_overrides(experiment.name, base, config)
    base.update(config)
    return base


def _run_unit(run_seed: Callable, name: str, config: dict, seed: int, progress: bool,
              workdir: str | None) -> dict:
    """One unit (a sub-configuration of one seed) wherever it runs: its metrics, normalised
    as the checkpoint files keep them, with ``seconds`` of wall time."""
    t = time.perf_counter()
    with _units.working_in(None if workdir is None else Path(workdir)):
        metrics = run_seed(dict(config), seed, progress)
    if not isinstance(metrics, Mapping):
        raise TypeError(f"experiment {name!r} returned {type(metrics).__name__}, not a dict")
    metrics = dict(metrics)
    metrics.setdefault("seconds", time.perf_counter() - t)
    return _units.normalise(metrics)


def _check_parallel(jobs, cluster):
    """The cluster the run uses (None: in this process); ``jobs`` and ``cluster`` as
    :func:`run` declares them."""
    if cluster is None:
        return None if jobs == 1 else f"local:{int(jobs)}"
    if isinstance(cluster, str):
        from qdensity.cluster import parse_cluster

        parse_cluster(cluster)  # refuse a bad address before any work
        if cluster.strip() == "local" and jobs > 1:
            return f"local:{int(jobs)}"
    if jobs != 1:
        raise ValueError(f"give jobs ({jobs}) or cluster ({cluster!r}), not both: jobs=N "
                         "means cluster='local:N'")
    return cluster


def _split(experiment: Experiment, settings: dict) -> list[dict]:
    if experiment.units is None:
        return [settings]
    parts = experiment.units(dict(settings))
    if not isinstance(parts, list) or not parts or not all(isinstance(p, dict) for p in parts):
        raise TypeError(f"experiment {experiment.name!r}: units(config) must return a "
                        f"non-empty list of dicts, got {parts!r}")
    return parts


@validates(
    name=Instance(str), mode=Options(MODES),
    seeds=[Interval(int, 1, MAX_SEEDS),
           SequenceOf(Interval(int, 0, 2**32 - 1), max_len=MAX_SEEDS), None],
    config=[Instance(Mapping), None], out=[FilePath(exists=None), None],
    jobs=Interval(int, 1, 1024), cluster=[Instance(str), Instance('distributed:Client'), None],
    retries=Interval(int, 0, 100), plot=Instance(bool), progress=[Instance(bool), None],
)
def run(name: str, *, mode: str = "quick", seeds=None, config: Mapping | None = None,
        out: str | os.PathLike | None = None, jobs: int = 1, cluster=None, retries: int = 2,
        plot: bool = True, progress: bool | None = None) -> ExperimentResult:
    """Run one of the paper's experiments over seeds; write its JSON and figures.

    Parameters
    ----------
    name : str
        One of :data:`EXPERIMENTS` (``equivariant``, ``orthoqnn-depth``, ``pyramid-shots``,
        ``moe``, ``reuploading``, ``lcu-vs-single``, ``mixing-lemma``, ``noise``).
    mode : {"quick", "full"}
        ``quick``: at most a minute on two cores (tests, notebooks); ``full``: the paper's
        protocol as far as two cores allow (see the experiment's ``reductions``).
    seeds : int or sequence of int, optional
        Number of seeds (``0..S-1``) or the seeds themselves; default per mode.
    config : mapping, optional
        Overrides of the mode's settings (unknown keys are refused).
    out : path, optional
        Directory for ``<name>-<mode>.json``, the PNG figures and the finished units
        (``<name>-<mode>.units/``: a rerun with the same settings resumes from them); nothing
        is written if None.
    jobs : int
        Units run in this many local worker processes at once (``cluster="local:<jobs>"``;
        1: one after another in this process).
    cluster : str or distributed.Client, optional
        Where units run (:mod:`qdensity.cluster`): ``"local"``, ``"local:N"``,
        ``"tcp://HOST:PORT"`` (a running ``dask scheduler``) or a ``distributed.Client``.
    retries : int
        Times a unit that raises is tried again on the cluster (a unit whose worker is lost
        is rerun by the scheduler in any case).
    plot : bool
        Draw the figures (only with ``out``).
    progress : bool, optional
        Progress bars on a terminal (default: on; they stay silent when stderr is not a
        terminal).

    Returns
    -------
    ExperimentResult
        ``per_seed`` metrics (each with ``"worker"``: the Dask worker's address, several
        joined by ``", "`` when a seed's units ran on several, or ``"in-process"``),
        ``summary`` (scalar metric -> mean and 95% CI), ``curves`` (:func:`curve_summary`),
        ``figures`` (paths written) and the settings. The metrics do not depend on where the
        units ran.

    Raises
    ------
    OSError
        When no scheduler answers at a ``tcp://`` address within 10 s.

    Examples
    --------
    >>> from qdensity_paper import run
    >>> result = run("mixing-lemma", seeds=1, progress=False)  # doctest: +SKIP
    """
    experiment = get_experiment(name)
    settings = resolve_config(experiment, mode, config)
    seed_list = resolve_seeds(seeds, int(experiment.seeds.get(mode, 3)))
    target = _check_parallel(jobs, cluster)
    show = True if progress is None else bool(progress)
    t0 = time.perf_counter()
    parts = _split(experiment, settings)
    keys = [(seed, j) for seed in seed_list for j in range(len(parts))]
    done: dict[tuple[int, int], tuple[dict, str]] = {}
    store = None if out is None else _units.checkpoint_dir(out, name, mode, settings)
    workdir = None if out is None else str(Path(out).resolve())
    if store is not None:
        for seed, j in keys:
            record = _units.load_unit(store, seed, j, parts[j])
            if record is not None:
                done[seed, j] = record["metrics"], record["worker"]
    pending = [k for k in keys if k not in done]

    def finished(key, metrics, worker):
        done[key] = metrics, worker
        if store is not None:
            _units.save_unit(store, key[0], key[1], parts[key[1]], metrics, worker)
        bar.update()

    with progress_bar(len(keys), desc=f"{name} ({mode})", unit="unit", verbose=show,
                      leave=True) as bar:
        bar.update(len(keys) - len(pending))
        if pending and (target is not None and (len(pending) > 1 or cluster is not None)):
            arguments = [(experiment.run_seed, name, parts[j], seed, False, workdir)
                         for seed, j in pending]
            with open_client(target) as client:
                for i, metrics, worker in run_units(client, _run_unit, arguments,
                                                    retries=int(retries)):
                    finished(pending[i], metrics, worker)
        else:
            for seed, j in pending:
                finished((seed, j), _run_unit(experiment.run_seed, name, parts[j], seed, show,
                                              workdir), IN_PROCESS)
    per_seed = []
    for seed in seed_list:
        units = [done[seed, j] for j in range(len(parts))]
        metrics = [m for m, _ in units]
        row = (experiment.combine(dict(settings), metrics) if experiment.combine is not None
               else _units.merge_parts(metrics))
        row["worker"] = ", ".join(dict.fromkeys(w for _, w in units))
        per_seed.append(row)
    result = ExperimentResult(name=name, mode=mode, config=settings, seeds=seed_list,
                              per_seed=per_seed, curves=curve_summary(per_seed),
                              seconds=time.perf_counter() - t0)
    if out is not None:
        directory = Path(out)
        result.save(directory)
        if plot:
            result.figures = [Path(p).name for p in experiment.plot(result, directory)]
            result.save(directory)
    return result
