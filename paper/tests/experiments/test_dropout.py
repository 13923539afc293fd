"""The ``dropout`` experiment at its quick size: the shots its randomised training draws against
the count the protocol implies, reproducibility, refused settings."""

from __future__ import annotations

import pytest

from qdensity_paper import run
from qdensity_paper.dropout import MODELS
from qdensity_paper.reuploading import density_depth


def test_quick_run_counts_the_shots_of_the_randomised_training():
    """Per data point and step the dropout model draws ``shots`` for its forward estimate,
    ``shots`` for the mixture gradient and ``shots`` per parameter-shift pair of the sampled
    sub-unitary's 3 D angles: epochs x points x (2 + 6 D) x shots in all."""
    res = run("dropout", seeds=[0, 1], progress=False)
    cfg = res.config
    D = density_depth(cfg["layers"], cfg["experts"])
    expected = cfg["epochs"] * cfg["num_train"] * (2 + 6 * D) * cfg["shots"]
    for row in res.per_seed:
        assert row["dropout/training_shots"] == expected
        assert row["exact/training_shots"] == row["vanilla/training_shots"] == 0
        for m in MODELS:
            assert row[f"{m}/gap"] == pytest.approx(row[f"{m}/test_mse"] - row[f"{m}/train_mse"])
    again = run("dropout", seeds=[1], progress=False).per_seed[0]
    assert again["dropout/test_mse"] == res.per_seed[1]["dropout/test_mse"]


@pytest.mark.parametrize("override, match", [
    ({"setting": "both"}, "setting"),
    ({"shots": 0}, "shots"),
    ({"learning_rate": 0.0}, "learning_rate"),
])
def test_bad_settings_are_refused(override, match):
    with pytest.raises(ValueError, match=match):
        run("dropout", seeds=[0], config=override, progress=False)


def test_paper_mode_fixes_supp_j():
    with pytest.raises(ValueError, match="--paper fixes layers=50"):
        run("dropout", mode="paper", seeds=[0], config={"layers": 10}, progress=False)
