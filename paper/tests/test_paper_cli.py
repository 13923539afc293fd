"""``qdensity experiment``: listing, a small run through the command line, usage errors."""

import json

import pytest
from scipy import stats

from qdensity.cli.main import main
from qdensity_paper.registry import EXPERIMENTS


def test_list_json_names_every_experiment(capsys):
    assert main(["experiment", "--list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in rows] == list(EXPERIMENTS)
    assert all(r["title"] and r["paper"] for r in rows)


def test_small_run_writes_json_with_seeds_and_student_t_intervals(tmp_path, capsys):
    argv = ["experiment", "mixing-lemma", "--seeds", "0,4", "--out", str(tmp_path), "--json",
            "--no-plot", "--set", "student_epochs=1", "--set", "alpha_epochs=1",
            "--set", "train_size=16", "--set", "test_size=8", "--set", "num_qubits=3",
            "--set", "num_subunitaries=2"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    saved = json.loads((tmp_path / "mixing-lemma-quick.json").read_text())
    assert out["seeds"] == saved["seeds"] == [0, 4]
    assert saved["config"]["student_epochs"] == 1 and saved["mode"] == "quick"
    values = [row["lemma/distance_max"] for row in saved["per_seed"]]
    low, high = stats.t.interval(0.95, df=1, loc=sum(values) / 2, scale=stats.sem(values))
    ci = saved["summary"]["lemma/distance_max"]
    assert ci["low"] == pytest.approx(low) and ci["high"] == pytest.approx(high)


@pytest.mark.parametrize("argv, message", [
    (["experiment"], "name an experiment"),
    (["experiment", "nope"], "unknown experiment 'nope'"),
    (["experiment", "moe", "--set", "bogus=1"], "unknown settings"),
    (["experiment", "moe", "--seeds", "0,0"], "seeds must be distinct"),
])
def test_bad_input_exits_2_with_a_message(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_quick_and_full_are_exclusive(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["experiment", "moe", "--quick", "--full"])
    assert exc.value.code == 2
