"""The sweep aggregation (qdensity_paper._sweeps.sweep_metrics) on hand-made trials: the
selected trial, which runs the curves show, and their shot axes, worked out by hand."""

import pytest

from qdensity_paper._sweeps import selected_run, sweep_metrics

RUNS = [  # val, test, curve, shots per point
    {"val_accuracy": 0.70, "test_accuracy": 0.85, "test_by_epoch": [0.5, 0.85],
     "shots_by_epoch": [10.0, 20.0]},
    {"val_accuracy": 0.90, "test_accuracy": 0.60, "test_by_epoch": [0.4, 0.60],
     "shots_by_epoch": [30.0, 40.0]},
    {"val_accuracy": 0.90, "test_accuracy": 0.95, "test_by_epoch": [0.7, 0.95],
     "shots_by_epoch": [50.0, 60.0]},
]


def test_selected_run_is_the_first_best_validation():
    assert selected_run(RUNS) == 1  # trials 1 and 2 tie at 0.90: the first
    with pytest.raises(ValueError, match="runs"):
        selected_run([])


def test_curves_of_the_selected_run_with_its_own_shots_and_first_epoch():
    metrics, curves = sweep_metrics("m", RUNS, 0, None, curves="selected", first_epoch=5)
    assert metrics["m/selected_accuracy"] == 0.60
    assert metrics["m/runs_above"] == 2 and metrics["m/runs_of"] == 3
    assert metrics["m/runs_above_mean"] == pytest.approx(0.90)
    assert curves["m/test_vs_epoch"]["x"] == [5.0, 6.0]
    assert curves["m/test_vs_epoch"]["y"] == [0.4, 0.60]
    assert curves["m/test_vs_shots"]["x"] == [30.0, 40.0]


def test_curves_above_the_threshold_and_over_all_runs():
    _, above = sweep_metrics("m", RUNS, 0, 100.0)  # runs 0 and 2 reach 0.8
    assert above["m/test_vs_epoch"]["y"] == pytest.approx([0.6, 0.9])
    assert above["m/test_vs_shots"]["x"] == [100.0, 200.0]
    _, every = sweep_metrics("m", RUNS, 0, None, curves="all")
    assert every["m/test_vs_epoch"]["y"] == pytest.approx([1.6 / 3, 2.4 / 3])
    assert every["m/test_vs_shots"]["x"] == pytest.approx([30.0, 40.0])
    with pytest.raises(ValueError, match="curves"):
        sweep_metrics("m", RUNS, 0, 1.0, curves="best")
