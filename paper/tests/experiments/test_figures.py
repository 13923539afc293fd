"""Figures: a model keeps its colour in every panel; confidence bands stay inside the plotted
metric's range (a 2-seed accuracy interval reaches far outside [0, 1])."""

from __future__ import annotations

import numpy as np

from qdensity_paper._common import curve, curve_colours, plot_curves
from qdensity_paper.registry import curve_summary
from qdensity_paper.results import ExperimentResult


def test_colours_follow_labels_not_panel_order():
    colours = curve_colours(["T_2", "vanilla", "density", "vanilla", "density"])
    assert colours == {"T_2": "black", "vanilla": "C0", "density": "C1"}


def test_bands_clipped_and_colours_fixed(tmp_path, monkeypatch):
    from matplotlib.axes import Axes

    per_seed = [{"curves": {"a/acc": curve([1, 2], [0.05, 0.95], "epoch", "test accuracy"),
                            "b/acc": curve([1, 2], [0.5, 0.5], "epoch", "test accuracy"),
                            "truth/fit": curve([1, 2], [1.0, 2.0], "x", "y")}},
                {"curves": {"a/acc": curve([1, 2], [0.9, 0.1], "epoch", "test accuracy"),
                            "b/acc": curve([1, 2], [0.6, 0.4], "epoch", "test accuracy"),
                            "truth/fit": curve([1, 2], [1.0, 2.0], "x", "y")}}]
    result = ExperimentResult("x", "quick", {}, [0, 1], per_seed,
                              curves=curve_summary(per_seed))
    assert min(result.curves["a/acc"]["low"]) < 0  # t with one degree of freedom
    bands, lines = [], []
    real_fill, real_plot = Axes.fill_between, Axes.plot
    monkeypatch.setattr(Axes, "fill_between", lambda self, x, lo, hi, **kw: (
        bands.append((np.asarray(lo), np.asarray(hi), kw["color"])), real_fill(self, x, lo, hi,
                                                                              **kw))[1])
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **kw: (
        lines.append((kw.get("label"), kw.get("color"))), real_plot(self, *a, **kw))[1])
    labels = {"a/acc": "density", "b/acc": "vanilla", "truth/fit": "T_2"}
    plot_curves(result, [("one", ["a/acc", "b/acc"]), ("two", ["truth/fit", "b/acc", "a/acc"])],
                tmp_path / "f.png", labels=labels, y_labels=(None, "what is plotted"))
    accuracy_bands = [(lo, hi) for lo, hi, colour in bands if colour != "black"]
    assert len(accuracy_bands) == 4
    for lo, hi in accuracy_bands:
        assert lo.min() >= 0.0 and hi.max() <= 1.0
    by_label: dict = {}
    for label, colour in lines:
        by_label.setdefault(label, set()).add(colour)
    assert all(len(c) == 1 for c in by_label.values()), by_label
    assert by_label["T_2"] == {"black"}
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"


def test_sweep_label_names_the_runs_each_seed_averages():
    """Fig. 11b's curves average each seed's runs above 80%, a count that varies: the y label
    says so, with the range and the number of seeds (not one seed's count)."""
    from qdensity_paper.pyramid_shots import averaged_label

    rows = [{"pure/runs_above": a, "odd_even/runs_above": b, "pure/runs_of": 32}
            for a, b in ((13, 9), (11, 16), (19, 14))]
    result = ExperimentResult("pyramid-shots", "paper", {"trials": 32}, [0, 1, 2], rows)
    label = averaged_label(result, ["pure", "odd_even"])
    assert "9-19 of 32" in label and "3 seeds" in label and "test accuracy" in label
    plain = ExperimentResult("pyramid-shots", "full", {}, [0, 1], [{}, {}])
    assert averaged_label(plain, ["pure"]) == "test accuracy, mean of 2 seeds"


def test_noise_figures_keep_one_colour_per_method(tmp_path, monkeypatch):
    """The four noise figures of the committed run, redrawn: every label has one colour in
    all of them (a method's colour used to change between figures)."""
    from pathlib import Path

    from matplotlib.axes import Axes

    from qdensity_paper.registry import get_experiment

    lines = []
    real_plot = Axes.plot
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **kw: (
        lines.append((kw.get("label"), kw.get("color"))), real_plot(self, *a, **kw))[1])
    path = Path(__file__).resolve().parents[3] / "results" / "noise-full.json"
    result = ExperimentResult.load(path)
    assert len(get_experiment("noise").plot(result, tmp_path)) == 4
    by_label: dict = {}
    for label, colour in lines:
        if label is not None:  # one method: "device, raw" in one figure, "raw" in another
            by_label.setdefault(label.removeprefix("device, "), set()).add(colour)
    assert len(by_label) >= 5
    assert all(len(c) == 1 for c in by_label.values()), by_label


def test_the_lcu_figure_draws_each_model_under_one_label_and_colour(tmp_path, monkeypatch):
    """The committed lcu-vs-single paper run, redrawn: the LCU model is one label and one
    colour in the accuracy-vs-epochs and the accuracy-vs-shots panels (it was orange in one
    and green in the other)."""
    from pathlib import Path

    from matplotlib.axes import Axes

    from qdensity_paper.registry import get_experiment

    lines = []
    real_plot = Axes.plot
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **kw: (
        lines.append((kw.get("label"), kw.get("color"))), real_plot(self, *a, **kw))[1])
    path = Path(__file__).resolve().parents[3] / "results" / "lcu-vs-single-paper.json"
    get_experiment("lcu-vs-single").plot(ExperimentResult.load(path), tmp_path)
    drawn = [(label, colour) for label, colour in lines if label is not None]
    lcu = {label for label, _ in drawn if "LCU" in label}
    assert len(lcu) == 1
    for model in (*lcu, "single circuit"):
        assert sum(label == model for label, _ in drawn) == 2  # both accuracy panels
        assert len({colour for label, colour in drawn if label == model}) == 1
