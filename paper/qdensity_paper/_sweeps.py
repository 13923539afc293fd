"""The paper's per-model optuna sweeps inside an experiment (``moe``, ``pyramid-shots``,
``lcu-vs-single``).

One study per (experiment, model, seed), over :data:`qdensity.learning.sweep.PAPER_SPACE`,
run through :func:`qdensity.learning.sweep.run_trials` (TPE after its random start-up trials,
:func:`~qdensity.learning.sweep.startup_trials`). When the run writes files the studies live in
``<out>/<experiment>-sweeps.db`` (SQLite) so that a rerun, or another worker's retry of the
unit, resumes their finished trials; otherwise in memory. The trials of a study are scored on a
validation split; each records its test accuracy after every epoch. :func:`sweep_metrics`
aggregates them the paper's way: mean, spread and best over the trials, "the best x/32 runs
above 80%" (:func:`qdensity_paper.results.runs_above`), and the trial that the search
selects (best validation accuracy, :func:`selected_run`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from qdensity.learning.sweep import MEMORY, PAPER_SPACE, open_study, run_trials, suggest_params
from qdensity_paper._common import curve
from qdensity_paper.registry import work_directory
from qdensity_paper.results import bootstrap_ci, runs_above

__all__ = ["THRESHOLD", "CURVES", "sweep_model", "sweep_metrics", "selected_run"]

#: The paper's "runs above 80%" threshold (hyperparameters appendix, Fig. 11b).
THRESHOLD = 0.8

#: Which trials a sweep's curves show: the mean over the runs above the threshold (Fig. 11b),
#: over every run (Fig. 15), or the selected run alone (one tuned model per curve, Supp. C).
CURVES = ("above", "all", "selected")


def _study(experiment: str, cfg: dict, seed: int, index: int, prefix: str, trials: int):
    from qdensity.learning.sweep import settings_hash

    directory = work_directory()
    if directory is not None:  # --out may name a folder the run has not made yet
        directory.mkdir(parents=True, exist_ok=True)
    storage = (MEMORY if directory is None
               else f"sqlite:///{directory / f'{experiment}-sweeps.db'}")
    settings = {**{k: v for k, v in cfg.items() if k != "models"}, "seed": seed,
                "model": prefix}
    return open_study(f"{experiment}-seed{seed}-{prefix}-{settings_hash(settings)}", storage,
                      seed=seed * 1000 + index, n_trials=trials, settings=settings,
                      grace_period=None if directory is None else 60)


def sweep_model(experiment: str, cfg: dict, seed: int, index: int, prefix: str, trials: int,
                train: Callable[[dict, int], dict], bar=None) -> list[dict]:
    """Run (or resume) the sweep of one model of one seed.

    Parameters
    ----------
    experiment : str
        Experiment name (names the storage file and the study).
    cfg : dict
        The run's settings (with ``models``, which is left out of the study's settings so that
        a unit of work and the whole seed share the study).
    seed : int
    index : int
        The model's index among all models of the experiment (seeds its sampler).
    prefix : str
        The model's metric prefix.
    trials : int
        COMPLETE trials of the study.
    train : callable
        ``train(params, trial_number) -> dict`` with ``val_accuracy`` (the score),
        ``test_accuracy`` and ``test_by_epoch``, and any other JSON values to keep with the
        trial (``shots_by_epoch``, ...); ``trial_number`` is the retried trial's number when a
        dead worker's trial runs again, so that it reruns with its own seeds.
    bar : progress bar, optional
        Updated once per trial.

    Returns
    -------
    list of dict
        The first ``trials`` COMPLETE trials in order: ``params``, ``val_accuracy`` and what
        ``train`` returned beside it.
    """
    from qdensity.learning.sweep import retried_from

    study = _study(experiment, cfg, seed, index, prefix, trials)

    def evaluate(trial):
        t = retried_from(trial)
        t = trial.number if t is None else t
        res = train(suggest_params(trial, PAPER_SPACE), t)
        for key, value in res.items():
            if key != "val_accuracy":
                trial.set_user_attr(key, value)
        if bar is not None:
            bar.update()
        return res["val_accuracy"]

    run_trials(study, evaluate, trials)
    done = sorted((t for t in study.get_trials(deepcopy=False) if t.state.name == "COMPLETE"),
                  key=lambda t: t.number)[:trials]
    return [{"params": dict(t.params), "val_accuracy": float(t.value), **t.user_attrs}
            for t in done]


def validation_split(X_tr: np.ndarray, y_tr: np.ndarray, fraction: float, seed: int):
    """The sweep's validation rows: ``fraction`` of the training rows, stratified by class
    where every class can split (else at random), fixed by ``seed``.

    Returns
    -------
    (X_train, y_train, X_validation, y_validation)
    """
    from sklearn.model_selection import train_test_split

    counts = np.unique(y_tr, return_counts=True)[1]
    X_tr, X_va, y_tr, y_va = train_test_split(X_tr, y_tr, test_size=float(fraction),
                                              random_state=seed,
                                              stratify=y_tr if counts.min() >= 2 else None)
    return X_tr, y_tr, X_va, y_va


def selected_run(runs: list[dict]) -> int:
    """Index of the run the search selects: the best validation accuracy (the first of equals)."""
    if not runs:
        raise ValueError("runs is empty: a sweep has at least one trial")
    return max(range(len(runs)), key=lambda i: (runs[i]["val_accuracy"], -i))


def sweep_metrics(prefix: str, runs: list[dict], seed: int, shots_per_epoch: float | None,
                  threshold: float = THRESHOLD, curves: str = "above", first_epoch: int = 1
                  ) -> tuple[dict, dict]:
    """The paper's aggregation of one model's sweep.

    Parameters
    ----------
    prefix : str
        Metric prefix of the model.
    runs : list of dict
        From :func:`sweep_model`.
    seed : int
        Seed of the bootstrap interval.
    shots_per_epoch : float or None
        Shots one epoch of training spends (for ``test_vs_shots``); None: each run's own
        ``shots_by_epoch`` (the shots spent by each point of its ``test_by_epoch``), averaged
        over the runs shown.
    threshold : float
        The "runs above" accuracy.
    curves : {"above", "all", "selected"}
        The curves average the runs above the threshold (Fig. 11b; every run when none reach
        it), every run, or show the selected run (:func:`selected_run`) alone.
    first_epoch : int
        The epoch of the first point of ``test_by_epoch`` (0: it is the accuracy before
        training).

    Returns
    -------
    metrics : dict
        ``{prefix}/mean_accuracy``, ``best_accuracy``, ``std_accuracy``, ``ci_low``/``ci_high``
        (bootstrap over the trials), ``selected_accuracy`` (test accuracy of the trial with the
        best validation accuracy), ``runs_above`` (x of "x/N runs above 80%"), ``runs_of``
        (N) and ``runs_above_mean`` (their mean test accuracy; absent when none reach it).
    curves : dict
        ``{prefix}/trials`` (test accuracy per trial), ``test_vs_epoch`` and ``test_vs_shots``
        of the runs ``curves`` names (the curve's label says which).
    """
    if curves not in CURVES:
        raise ValueError(f"curves must be one of {CURVES}, got {curves!r}")
    acc = np.array([r["test_accuracy"] for r in runs], dtype=float)
    ci = (bootstrap_ci(acc, seed=seed) if acc.size > 1
          else {"low": acc[0], "high": acc[0]})
    above = runs_above(acc, threshold)
    chosen = selected_run(runs)
    metrics = {f"{prefix}/mean_accuracy": float(acc.mean()),
               f"{prefix}/best_accuracy": float(acc.max()),
               f"{prefix}/std_accuracy": float(acc.std()),
               f"{prefix}/ci_low": float(ci["low"]), f"{prefix}/ci_high": float(ci["high"]),
               f"{prefix}/selected_accuracy": float(acc[chosen]),
               f"{prefix}/runs_above": above["count"], f"{prefix}/runs_of": above["of"]}
    if above["mean"] is not None:
        metrics[f"{prefix}/runs_above_mean"] = above["mean"]
    if curves == "selected":
        kept, which = [runs[chosen]], "the selected trial"
    else:
        kept = [r for r in runs if curves == "above" and r["test_accuracy"] >= threshold]
        which = f"mean over the {len(kept)} runs >= {threshold:g}"
        if not kept:
            kept, which = runs, "mean over trials"
    mean_curve = np.mean([r["test_by_epoch"] for r in kept], axis=0)
    ep = np.arange(first_epoch, first_epoch + mean_curve.size)
    shots = (ep * shots_per_epoch if shots_per_epoch is not None
             else np.mean([r["shots_by_epoch"] for r in kept], axis=0))
    label = f"test accuracy ({which})"
    out = {f"{prefix}/trials": curve(np.arange(acc.size), acc, "trial", "test accuracy"),
           f"{prefix}/test_vs_epoch": curve(ep, mean_curve, "epoch", label),
           f"{prefix}/test_vs_shots": curve(shots, mean_curve, "shots spent in training", label)}
    return metrics, out
