"""Pieces the experiments share: shot accounting for exact runs, training curves, figures."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from qdensity.experiments.results import ExperimentResult
from qdensity.gradients.density import density_gradient_plan

__all__ = ["circuits_per_row", "epoch_curves", "plot_curves", "require_torch", "curve"]


def circuits_per_row(model, X_row, method: str = "auto") -> int:
    """Circuits one training step needs per data point: the gradient circuits of every
    sub-unitary plus one forward circuit per sub-unitary (what a sampled run would execute).

    Exact runs count their shots as ``circuits_per_row x rows x shots_per_circuit``: the
    shots the same training would need on hardware (issue "experiments").

    Parameters
    ----------
    model : DensityQNN
    X_row : array_like, shape (1, d)
        One encoded input (the plan's size does not depend on its values).
    method : {"auto", "shift", "commuting"}
    """
    plan = density_gradient_plan(model, np.atleast_2d(np.asarray(X_row, dtype=float))[:1],
                                 method=method)
    return int(plan.num_circuits)


def curve(x, y, x_label: str, y_label: str) -> dict:
    """A curve in the form :func:`qdensity.experiments.run` summarises."""
    x = [float(v) for v in x]
    y = [float(v) for v in y]
    if len(x) != len(y):
        raise ValueError(f"a curve needs as many x as y values, got {len(x)} and {len(y)}")
    return {"x": x, "y": y, "x_label": x_label, "y_label": y_label}


def epoch_curves(history, prefix: str, shots_per_epoch: float | None = None,
                 metric: str = "test accuracy") -> dict:
    """Curves of a fitted estimator's ``history_.epochs``: test metric against epochs and
    against shots (the ledger's, or ``shots_per_epoch x epoch`` for exact runs).

    Returns
    -------
    dict
        ``{prefix}/test_vs_epoch``, ``{prefix}/train_vs_epoch`` and ``{prefix}/test_vs_shots``.
    """
    rows = history.epochs
    epochs = [r["epoch"] + 1 for r in rows]
    if shots_per_epoch is None:
        shots = [r["shots"] for r in rows]
    else:
        shots = [shots_per_epoch * e for e in epochs]
    out = {f"{prefix}/train_vs_epoch": curve(epochs, [r["train_metric"] for r in rows],
                                             "epoch", f"train {metric.split()[-1]}")}
    if rows and "test_metric" in rows[0]:
        test = [r["test_metric"] for r in rows]
        out[f"{prefix}/test_vs_epoch"] = curve(epochs, test, "epoch", metric)
        out[f"{prefix}/test_vs_shots"] = curve(shots, test, "shots", metric)
    return out


def plot_curves(result: ExperimentResult, panels: Sequence[tuple[str, Sequence[str]]],
                path: str | Path, title: str | None = None,
                labels: Mapping[str, str] | None = None, log_x: Sequence[bool] = ()) -> Path:
    """One figure, one panel per ``(panel title, curve names)``: each curve's mean over seeds
    with its 95% confidence band (``result.curves``). Missing curves are skipped.

    Returns
    -------
    Path
        The PNG written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = labels or {}
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.8), squeeze=False)
    for i, (ax, (panel, names)) in enumerate(zip(axes[0], panels, strict=True)):
        for name in names:
            c = result.curves.get(name)
            if c is None:
                continue
            line, = ax.plot(c["x"], c["mean"], marker="o", ms=3,
                            label=labels.get(name, name.split("/")[0]))
            ax.fill_between(c["x"], c["low"], c["high"], color=line.get_color(), alpha=0.2)
            ax.set_xlabel(c["x_label"])
            ax.set_ylabel(c["y_label"])
        if i < len(log_x) and log_x[i]:
            ax.set_xscale("log")
        ax.set_title(panel)
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    n = len(result.seeds)
    fig.suptitle(f"{title or result.name} ({result.mode}, {n} seed{'s' * (n != 1)}, "
                 "mean and 95% CI)", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def require_torch(experiment: str):
    """``torch``, or an ImportError that says how to install it."""
    try:
        import torch
    except ImportError as exc:  # pragma: no cover - CI installs the extra
        raise ImportError(f"experiment {experiment!r} trains a hybrid PyTorch model; install "
                          "the extra: pip install 'qdensity[torch]'") from exc
    return torch
