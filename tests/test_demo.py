"""``qdensity demo`` (:mod:`qdensity.demo`): a run smaller than ``--quick`` checked
for its invariants (ceilings reported, the shot budget never exceeded, the curve's shots
counted from zero), and bad settings refused by name. The scientific result (the density model
near its ceiling, the pure model lagging) is measured in the README, not asserted here."""

import json

import numpy as np
import pytest

from qdensity.demo import DemoConfig, run_demo


def test_tiny_demo_invariants(tmp_path):
    cfg = DemoConfig.quick(budget=1000, curve_points=4, seed=3)
    res = run_demo(cfg, output_dir=tmp_path, verbose=False)
    json.dumps(res)  # what --json prints
    # per data point on 4 qubits: pure 4 x 6 shift circuits + 1 forward; density 3 + 3
    per_point = {"pure": 25, "density": 6}
    for name, method in (("pure", "shift"), ("density", "commuting")):
        r = res[name]
        assert r["gradient_method"] == method
        assert 0.0 <= r["ceiling"] <= 1.0 and 0.0 <= r["accuracy"] <= 1.0
        step_shots = cfg.batch_size * per_point[name] * cfg.shots
        assert r["shots"] <= cfg.budget < r["shots"] + step_shots
        assert r["shots"] == r["steps"] * step_shots == r["circuits"] * cfg.shots
        shots, acc = (np.array(v) for v in zip(*r["curve"], strict=True))
        assert shots[0] == 0 and shots[-1] == r["shots"]
        assert np.all(np.diff(shots) > 0) and np.all(shots <= cfg.budget)
        assert np.all((acc >= 0) & (acc <= 1)) and acc[-1] == pytest.approx(r["accuracy"])
    assert res["config"] == {**DemoConfig.quick().__dict__, "budget": 1000, "curve_points": 4,
                             "seed": 3}
    assert (tmp_path / "qdensity-demo.png").stat().st_size > 1000


@pytest.mark.parametrize("setting, value", [
    ("num_qubits", 1), ("num_classes", 11), ("num_classes", 1), ("shots", 0), ("budget", -5),
    ("batch_size", 2.5), ("learning_rate", 0.0), ("curve_points", True), ("test_size", 3),
])
def test_bad_settings_are_named(setting, value, tmp_path):
    with pytest.raises(ValueError, match=setting):
        run_demo(DemoConfig.quick(**{setting: value}), output_dir=tmp_path, verbose=False)


def test_quick_says_it_is_only_a_smoke_test(tmp_path, capsys):
    run_demo(DemoConfig.quick(budget=1000, curve_points=2), output_dir=tmp_path, plot=False)
    out = capsys.readouterr().out
    assert out.count("smoke test") == 2 and "not expected to learn" in out
    from qdensity.cli import main

    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    assert "smoke test of the install" in " ".join(capsys.readouterr().out.split())
