"""--paper mode: every experiment of the paper has its settings at the paper's stated values
(read here off the paper's text, not off the code), overrides of fixed settings are refused."""

from __future__ import annotations

import pytest

from qdensity_paper.protocol import PaperProtocol, resolve_paper
from qdensity_paper.registry import EXPERIMENTS, MODES, get_experiment, resolve_config

# name -> settings the paper states (Methods, Fig. captions, Supp. C, H, J, hyperparameters)
STATED = {
    "equivariant": {"num_qubits": 10, "noise_std": 1.8, "train_size": 1000, "test_size": 100,
                    "batch_size": 20, "learning_rate": 0.001, "alpha_init": [0.99, 0.01],
                    "pretrain_steps": 1000, "density_steps": 1000},
    "orthoqnn-depth": {"num_qubits": 10, "depths": [1, 2, 3, 4, 9], "pretrain_epochs": 25,
                       "epochs": 25, "mixture": "moe", "dataset": "mnist"},
    "pyramid-shots": {"num_qubits": 8, "dataset": "mnist"},
    "reuploading": {"experts": 5, "batch_size": 5, "learning_rate": 0.001, "setting": "both",
                    "experts_at_max": [2, 7]},
    "lcu-vs-single": {"num_qubits": 10, "pretrain_epochs": 20, "dataset": "mnist"},
    "moe": {"num_qubits": 8, "trials": 32},
    "mixing-lemma": {"num_qubits": 10, "num_subunitaries": 9},
}


def test_paper_is_a_mode():
    assert "paper" in MODES


@pytest.mark.parametrize("name", sorted(STATED))
def test_paper_settings_are_the_papers(name):
    exp = get_experiment(name)
    settings = resolve_config(exp, "paper", None)
    for key, value in STATED[name].items():
        assert settings[key] == value, key
    # same keys as the other modes: run_seed reads them all
    assert set(settings) == set(exp.full)
    assert exp.seeds["paper"] >= 1


def test_noise_has_no_paper_mode():
    assert "noise" in EXPERIMENTS
    with pytest.raises(ValueError, match="no --paper mode"):
        resolve_config(get_experiment("noise"), "paper", None)


def test_fixed_settings_refused_open_ones_taken():
    exp = get_experiment("equivariant")
    with pytest.raises(ValueError, match=r"--paper fixes density_steps=1000.*--full"):
        resolve_config(exp, "paper", {"density_steps": 100})
    same = resolve_config(exp, "paper", {"density_steps": 1000})  # the paper's value: fine
    assert same["density_steps"] == 1000
    other = resolve_config(exp, "paper", {"angle_scale": 1.5708, "pretrain_steps": 500})
    assert other["angle_scale"] == 1.5708 and other["pretrain_steps"] == 500
    with pytest.raises(ValueError, match="unknown settings"):
        resolve_config(exp, "paper", {"epochs": 3})
    with pytest.raises(TypeError, match="mapping"):
        resolve_paper("x", exp.protocol, [("a", 1)])


def test_protocol_refuses_inconsistent_declarations():
    with pytest.raises(ValueError, match="lacks"):
        PaperProtocol(settings={"a": 1}, fixed=("b",))
    with pytest.raises(ValueError, match="both fixed and ambiguous"):
        PaperProtocol(settings={"a": 1}, fixed=("a",), readings={"a": "?"})


def test_cli_paper_flag_refuses_a_fixed_setting(capsys):
    from qdensity.cli.main import main

    code = main(["experiment", "mixing-lemma", "--paper", "--set", "num_qubits=4", "--no-plot"])
    assert code != 0
    assert "--paper fixes num_qubits=10" in capsys.readouterr().err


def test_reuploading_full_run_is_the_paper_protocol():
    # EXPERIMENTS.md quotes results/reuploading-full.json as the --paper run: same settings
    exp = get_experiment("reuploading")
    assert dict(exp.full) == dict(exp.protocol.settings)
    assert exp.seeds["full"] == exp.seeds["paper"]
