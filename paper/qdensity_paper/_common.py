"""Pieces the experiments share: shot accounting for exact runs, training curves, figures."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from qdensity.gradients.density import density_gradient_plan
from qdensity.io import atomic_path
from qdensity_paper.results import ExperimentResult, metric_bounds

__all__ = ["circuits_per_row", "epoch_curves", "plot_curves", "curve_colours", "figure_name",
           "require_torch", "curve"]


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
    """A curve in the form :func:`qdensity_paper.run` summarises."""
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


def figure_name(result: ExperimentResult, name: str) -> str:
    """The file name of a figure of ``result``: ``name`` for a ``full`` run (the names the
    committed results use), ``name`` with the mode after the experiment's name otherwise, so
    that a ``--paper`` or ``--quick`` run beside a full one does not overwrite its figures.

    Examples
    --------
    >>> r = ExperimentResult("pyramid-shots", "paper", {}, [], [])
    >>> figure_name(r, "pyramid-shots-x.png")
    'pyramid-shots-paper-x.png'
    """
    if result.mode == "full" or not name.startswith(result.name):
        return name
    return f"{result.name}-{result.mode}{name[len(result.name):]}"


#: Colours of the curves, in order of the first appearance of their label in a figure.
_PALETTE = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C8", "C9")


def curve_colours(labels: Sequence[str]) -> dict[str, str]:
    """One colour per distinct label, in order of first appearance, so that a model keeps its
    colour in every panel of a figure; a ground truth (label starting ``"T_"``) is black.

    Examples
    --------
    >>> curve_colours(["T_2", "vanilla", "density", "vanilla"])
    {'T_2': 'black', 'vanilla': 'C0', 'density': 'C1'}
    """
    out: dict[str, str] = {}
    for label in labels:
        if label in out:
            continue
        if label.startswith("T_"):
            out[label] = "black"
        else:
            out[label] = _PALETTE[sum(c != "black" for c in out.values()) % len(_PALETTE)]
    return out


def plot_curves(result: ExperimentResult, panels: Sequence[tuple[str, Sequence[str]]],
                path: str | Path, title: str | None = None,
                labels: Mapping[str, str] | None = None, log_x: Sequence[bool] = (),
                y_labels: Sequence[str | None] = (),
                thin: Mapping[str, Sequence[str]] | None = None,
                colours: Mapping[str, str] | None = None,
                split: Mapping[str, float] | None = None,
                gaps: Mapping[str, tuple[float, str]] | None = None,
                points: Mapping[str, Sequence[str]] | None = None,
                breaks: Mapping[str, int] | None = None, mode: str | None = None) -> Path:
    """One figure, one panel per ``(panel title, curve names)``: each curve's mean over seeds
    with its 95% confidence band (``result.curves``). Missing curves are skipped.

    A model keeps its colour across panels (:func:`curve_colours` on the labels); bands are
    clipped to the range of the plotted metric (:func:`~qdensity_paper.results.
    metric_bounds` of the curve's y label), so no band leaves ``[0, 1]`` for an accuracy.

    Parameters
    ----------
    y_labels : sequence of str or None, optional
        Per panel, the y-axis label (default: the last curve's own y label); a panel that holds
        several quantities needs one that names them all.
    thin : mapping, optional
        Curve name -> names of curves drawn as thin lines of its colour without bands (the
        pretrained sub-unitaries beside their density model, as in the paper's Fig. 7).
    colours : mapping, optional
        Label -> colour, for labels that must keep a colour across figures too (the others
        follow :func:`curve_colours`).
    split : mapping, optional
        Curve name -> x: the curve is drawn solid up to x and thin and dashed after it (a base
        model trained on past the point where its density version leaves it).
    gaps : mapping, optional
        Curve name -> ``(x_from, label)``: the span from ``x_from`` to the curve's first x is
        shaded in its colour and labelled, and no line joins the curve to anything before its
        first point (the paper's Fig. 5b gap: shots spent pretraining a second sub-unitary
        before the density model's first step).
    points : mapping, optional
        Curve name -> names of curves drawn as open markers of its colour, no line (single
        points such as the accuracy of a warm start before its first step).
    breaks : mapping, optional
        Curve name -> number of points before a restart: no line (and no band) joins the
        points before it to those after (the mean sub-model of Fig. 7's pretraining epochs
        and the warm-started density model after them).
    mode : str, optional
        What the title says the run is (default: ``result.mode``).

    Returns
    -------
    Path
        The PNG written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = labels or {}
    thin = thin or {}
    split, gaps, points, breaks = split or {}, gaps or {}, points or {}, breaks or {}
    names_in_order = [name for _, names in panels for name in names if name in result.curves]
    colours = {**curve_colours([labels.get(n, n.split("/")[0]) for n in names_in_order]),
               **(colours or {})}
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.8), squeeze=False)
    for i, (ax, (panel, names)) in enumerate(zip(axes[0], panels, strict=True)):
        for name in names:
            c = result.curves.get(name)
            if c is None:
                continue
            label = labels.get(name, name.split("/")[0])
            colour = colours[label]
            for sub in thin.get(name, ()):
                t = result.curves.get(sub)
                if t is not None:
                    ax.plot(t["x"], t["mean"], color=colour, lw=0.6, alpha=0.6)
            x = np.asarray(c["x"], dtype=float)
            mean = np.asarray(c["mean"], dtype=float)
            c = dict(c)
            if name in breaks and 0 < breaks[name] < x.size:  # a gap in the line and band
                at = int(breaks[name])
                x = np.insert(x, at, np.nan)
                mean = np.insert(mean, at, np.nan)
                c["low"] = np.insert(np.asarray(c["low"], dtype=float), at, np.nan)
                c["high"] = np.insert(np.asarray(c["high"], dtype=float), at, np.nan)
            cut = np.isnan(x) | (x <= split.get(name, np.inf))
            after = ~cut  # the part past the split, drawn from the split point on
            if after.any():
                after[max(int(np.argmax(after)) - 1, 0)] = True
            ax.plot(x[cut], mean[cut], marker="o", ms=3, color=colour, label=label)
            if after.any():
                ax.plot(x[after], mean[after], ls="--", lw=0.8, color=colour, alpha=0.7,
                        label=f"{label}, trained on")
            if name in gaps and x.size:
                x_from, gap_label = gaps[name]
                ax.axvspan(float(x_from), float(x[0]), color=colour, alpha=0.12, lw=0,
                           label=gap_label)
            for sub in points.get(name, ()):
                t = result.curves.get(sub)
                if t is not None:
                    ax.plot(t["x"], t["mean"], ls="none", marker="o", ms=6, mfc="none",
                            color=colour, label=labels.get(sub, sub))
            lo_b, hi_b = metric_bounds(str(c.get("y_label", "")))
            if mean.size and (np.nanmin(mean) < lo_b or np.nanmax(mean) > hi_b):
                lo_b, hi_b = -np.inf, np.inf  # the label's range does not hold: no clipping
            low = np.clip(np.asarray(c["low"], dtype=float), lo_b, hi_b)
            high = np.clip(np.asarray(c["high"], dtype=float), lo_b, hi_b)
            ax.fill_between(x[cut], low[cut], high[cut], color=colour, alpha=0.2)
            if after.any():
                ax.fill_between(x[after], low[after], high[after], color=colour, alpha=0.07)
            ax.set_xlabel(c["x_label"])
            ax.set_ylabel(c["y_label"])
        if i < len(y_labels) and y_labels[i]:
            ax.set_ylabel(y_labels[i])
        if i < len(log_x) and log_x[i]:
            ax.set_xscale("log")
        ax.set_title(panel)
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    n = len(result.seeds)
    fig.suptitle(f"{title or result.name} ({mode or result.mode}, {n} seed{'s' * (n != 1)}, "
                 "mean and 95% CI)", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
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
