"""pyramid-shots at a size far below quick: shapes, invariants, shot accounting, settings."""

import json

import numpy as np
import pytest
from _rows import assert_rerun_resumes

from qdensity_paper import run

N = 4  # pyramid on 4 qubits: 6 RBS gates
TINY = {"num_qubits": N, "epochs": 2, "train_size": 40, "test_size": 20, "batch_size": 16,
        "evals_per_epoch": 2, "shots_per_circuit": 10}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, checked_run):
    out = tmp_path_factory.mktemp("pyramid")
    return checked_run("pyramid-shots", TINY, [0, 2], out), out


def test_seeds_files_and_cis(tiny):
    result, out = tiny
    # names beside the JSON, not the (absolute) path of the run's folder
    assert result.figures == ["pyramid-shots-quick.png"]
    assert json.loads((out / "pyramid-shots-quick.json").read_text())["figures"] == \
        ["pyramid-shots-quick.png"]


def test_circuit_counts_and_angles(tiny):
    result, _ = tiny
    gates = N * (N - 1) // 2
    seed = result.per_seed[0]
    # forward + four-term shift per RBS + four-term shift per loader angle (the Linear layer in
    # front of the loader trains), per sub-unitary
    assert seed["pure/circuits_per_row"] == 1 + 4 * gates + 4 * (N - 1)
    assert seed["pure/circuits/input_gradients"] == 4 * (N - 1)
    for m in ("odd_even", "compressed"):  # K = 2: one commuting circuit + one forward each
        assert seed[f"{m}/circuits_per_row"] == 2 * 2 + 2 * 4 * (N - 1)
        assert seed[f"{m}/circuits/parameter_gradients_k0"] == 1
        assert seed[f"{m}/circuits/forward"] == 2
    assert seed["pure/num_angles"] == seed["odd_even/num_angles"] == gates
    assert seed["compressed/num_angles"] == N - 1


def test_shots_curves(tiny):
    result, _ = tiny
    for seed in result.per_seed:
        rows = seed["train_rows"]
        assert rows == TINY["train_size"] and seed["test_rows"] == TINY["test_size"]
        for m in ("pure", "odd_even", "compressed"):
            c = seed["curves"][f"{m}/test_vs_shots"]
            assert len(c["x"]) == TINY["epochs"] * TINY["evals_per_epoch"]
            assert np.all(np.diff(c["x"]) > 0)
            per_row = seed[f"{m}/circuits_per_row"] * TINY["shots_per_circuit"]
            total = per_row * rows * TINY["epochs"]
            assert c["x"][-1] == seed[f"{m}/shots"] == total
            assert all(0.0 <= a <= 1.0 for a in c["y"])
            epochs = seed["curves"][f"{m}/test_vs_epoch"]["x"]
            assert epochs[-1] == TINY["epochs"] and np.all(np.diff(epochs) > 0)
        pure = seed["curves"]["pure/test_vs_shots"]
        budget = seed["odd_even/shots"]
        within = [a for s, a in zip(pure["x"], pure["y"], strict=True) if s <= budget]
        want = within[-1] if within else seed["pure/initial_test_accuracy"]
        assert seed["pure/test_accuracy_at_density_budget"] == want


def test_reproducible_and_models_subset():
    config = dict(TINY, epochs=1, models=["compressed"])
    a = run("pyramid-shots", seeds=[4], config=config, progress=False).per_seed[0]
    b = run("pyramid-shots", seeds=[4], config=config, progress=False).per_seed[0]
    a.pop("seconds"), b.pop("seconds")
    assert a == b
    assert set(a["curves"]) == {"compressed/test_vs_shots", "compressed/test_vs_epoch"}


def test_sweep_aggregates_and_resumes_from_storage(tmp_path):
    """A 2-trial sweep per (model, seed), 1 epoch: "x/N runs above 80%" counted by hand from
    the trials; a rerun whose finished units are gone resumes the studies from the storage
    (no new trials, the same numbers)."""

    import optuna

    pytest.importorskip("optuna")
    config = dict(TINY, epochs=1, trials=2, models=["pure", "odd_even"], test_size=20)
    tmp_path = tmp_path / "not-yet-made"
    first = run("pyramid-shots", seeds=[0], config=config, out=tmp_path, progress=False)
    row = first.per_seed[0]
    for m in ("pure", "odd_even"):
        trials = row["curves"][f"{m}/trials"]["y"]
        assert len(trials) == 2 and row[f"{m}/runs_of"] == 2
        assert row[f"{m}/runs_above"] == sum(a >= 0.8 for a in trials)
        assert row[f"{m}/mean_accuracy"] == pytest.approx((trials[0] + trials[1]) / 2)
        # one epoch on 32 training rows (40 less the 20% validation split)
        assert row[f"{m}/shots"] == row[f"{m}/circuits_per_row"] * 10 * 32
    budget = row["curves"]["odd_even/test_vs_shots"]["x"][-1]
    pure = row["curves"]["pure/test_vs_shots"]
    if pure["x"][-1] <= budget:
        assert row["pure/test_accuracy_at_density_budget"] == pure["y"][-1]
    else:  # the pure model's one epoch costs more than the density model's whole training
        assert "pure/test_accuracy_at_density_budget" not in row
    db = tmp_path / "pyramid-shots-sweeps.db"
    storage = f"sqlite:///{db}"
    names = [s.study_name for s in optuna.get_all_study_summaries(storage)]
    assert len(names) == 2  # one study per (model, seed)
    assert_rerun_resumes(run, "pyramid-shots", 0, config, tmp_path, storage, names, row, 2)


@pytest.mark.parametrize("change, setting", [
    ({"trials": -1}, "trials"), ({"validation_fraction": 0.6}, "validation_fraction"),
    ({"models": ["pyramid"]}, "models"), ({"models": []}, "models"),
    ({"models": ["pure", "pure"]}, "models"), ({"evals_per_epoch": 0}, "evals_per_epoch"),
    ({"learning_rate": 0}, "learning_rate"), ({"dataset": "svhn"}, "dataset"),
    ({"test_size": 5}, "test_size"), ({"batch_size": True}, "batch_size"),
])
def test_bad_settings(change, setting):
    with pytest.raises(ValueError, match=setting):
        run("pyramid-shots", seeds=1, config=dict(TINY, **change), progress=False)
