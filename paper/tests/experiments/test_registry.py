"""The experiment runner: seeds, settings, statistics over seeds, files written."""

import json

import numpy as np
import pytest
from scipy import stats

from qdensity_paper import registry
from qdensity_paper.registry import (
    Experiment,
    curve_summary,
    resolve_config,
    resolve_seeds,
)
from qdensity_paper.results import ExperimentResult


def _toy_seed(config, seed, progress):
    rng = np.random.default_rng(seed)
    acc = config["base"] + 0.01 * seed
    return {"acc": acc, "noise": float(rng.normal()),
            "curves": {"m/test_vs_epoch": {"x": [1, 2, 3], "y": [acc - 0.2, acc - 0.1, acc],
                                           "x_label": "epoch", "y_label": "test accuracy"}}}


def _toy_plot(result, directory):
    path = directory / "toy.png"
    path.write_bytes(b"png")
    return [path]


TOY = Experiment(name="toy", title="a toy", paper="none", quick={"base": 0.5},
                 full={"base": 0.7}, run_seed=_toy_seed, plot=_toy_plot,
                 seeds={"quick": 3, "full": 4})


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.setitem(registry.EXPERIMENTS, "toy", "toy")
    real = registry.get_experiment
    monkeypatch.setattr(registry, "get_experiment",
                        lambda name: TOY if name == "toy" else real(name))
    return TOY


def test_seeds_resolve():
    assert resolve_seeds(None, 3) == [0, 1, 2]
    assert resolve_seeds(2, 5) == [0, 1]
    assert resolve_seeds([4, 1], 5) == [4, 1]
    for bad, exc in ((0, ValueError), ([1, 1], ValueError), ([-1], ValueError),
                     ([], ValueError), ("3", TypeError), ([1.5], TypeError), (True, TypeError)):
        with pytest.raises(exc, match="seeds"):
            resolve_seeds(bad, 3)


def test_config_overrides_and_refuses_unknown_keys():
    assert resolve_config(TOY, "full", None) == {"base": 0.7}
    assert resolve_config(TOY, "quick", {"base": 0.1}) == {"base": 0.1}
    with pytest.raises(ValueError, match="unknown settings.*epochs.*known.*base"):
        resolve_config(TOY, "quick", {"epochs": 3})
    with pytest.raises(ValueError, match="mode must be one of"):
        resolve_config(TOY, "medium", None)


def test_unknown_experiment_lists_known_ones():
    with pytest.raises(ValueError, match="unknown experiment 'nope'; known: equivariant"):
        registry.get_experiment("nope")


def test_curve_summary_is_the_student_t_interval_point_by_point():
    ys = np.array([[0.1, 0.5], [0.3, 0.6], [0.2, 0.9]])
    per_seed = [{"curves": {"c": {"x": [1, 2], "y": list(y)}}} for y in ys]
    out = curve_summary(per_seed)["c"]
    for i in range(2):
        col = ys[:, i]
        low, high = stats.t.interval(0.95, df=2, loc=col.mean(), scale=stats.sem(col))
        assert out["mean"][i] == pytest.approx(col.mean())
        assert out["low"][i] == pytest.approx(low)
        assert out["high"][i] == pytest.approx(high)
    assert out["x"] == [1.0, 2.0]


def test_run_writes_json_and_figures_with_seed_statistics(toy, tmp_path):
    result = registry.run("toy", seeds=[0, 1, 2, 5], out=tmp_path, progress=False)
    accs = np.array([0.5, 0.51, 0.52, 0.55])
    low, high = stats.t.interval(0.95, df=3, loc=accs.mean(), scale=stats.sem(accs))
    assert result.seeds == [0, 1, 2, 5]
    assert result.summary["acc"]["mean"] == pytest.approx(accs.mean())
    assert result.summary["acc"]["low"] == pytest.approx(low)
    assert result.summary["acc"]["high"] == pytest.approx(high)
    assert result.curves["m/test_vs_epoch"]["mean"][-1] == pytest.approx(accs.mean())
    assert all(row["seconds"] >= 0 for row in result.per_seed)
    saved = json.loads((tmp_path / "toy-quick.json").read_text())
    assert saved["figures"] == ["toy.png"]  # its name beside the JSON, not a path
    assert saved["config"] == {"base": 0.5}
    assert "qiskit" in saved["versions"]
    again = ExperimentResult.load(tmp_path / "toy-quick.json")
    assert again.summary["acc"]["mean"] == pytest.approx(accs.mean())


def test_full_mode_uses_its_settings_and_seed_count(toy):
    result = registry.run("toy", mode="full", progress=False)
    assert result.seeds == [0, 1, 2, 3]
    assert result.summary["acc"]["mean"] == pytest.approx(0.7 + 0.015)


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True])
def test_bad_jobs(toy, jobs):
    error = TypeError if isinstance(jobs, (bool, float)) else ValueError  # wrong type, or value
    with pytest.raises(error, match="jobs must be an int >= 1"):
        registry.run("toy", jobs=jobs, progress=False)


def test_jobs_mean_a_local_cluster_of_that_many_workers():
    assert registry._check_parallel(1, None) is None  # in this process
    assert registry._check_parallel(3, None) == "local:3"
    assert registry._check_parallel(4, "local") == "local:4"
    assert registry._check_parallel(1, "tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    with pytest.raises(ValueError, match="give jobs \\(2\\) or cluster \\('local:3'\\)"):
        registry._check_parallel(2, "local:3")
    with pytest.raises(ValueError, match="unknown cluster address 'ssh://h'; allowed"):
        registry._check_parallel(1, "ssh://h")
