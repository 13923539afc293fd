"""The ``qdensity`` command: every sub-command, JSON outputs against independent numbers,
bad input gives a message and exit status 2; the demo at a tiny budget."""

import argparse
import json

import numpy as np
import pytest

from qdensity.cli import BUILDERS, build_circuit, main
from qdensity.cli.main import _parser


def _status(argv) -> int:
    """Exit status of ``qdensity ARGV`` (``--help`` exits through argparse)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    """Every sub-command, read off the parser (so a new one is covered without a new test)."""
    actions = [a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction)]
    assert len(actions) == 1
    return dict(actions[0].choices)


SUBCOMMANDS = sorted(_subcommands())


def test_the_parser_is_read():
    assert {"build", "transpile", "run", "table1", "export", "demo"} <= set(SUBCOMMANDS)


def test_help_everywhere(capsys):
    assert _status(["--help"]) == 0
    assert "usage" in capsys.readouterr().out


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_subcommand_has_help_and_json(command, capsys):
    assert _status([command, "--help"]) == 0
    text = capsys.readouterr().out
    assert "usage" in text and "--json" in text
    sub = _subcommands()[command]
    for action in sub._actions:
        if not isinstance(action, argparse._HelpAction):
            assert action.help and action.help.strip(), f"{command} {action.dest}: no help text"
    # --json parses (positional arguments filled with a placeholder; nothing is run)
    positional = ["x" for a in sub._actions if not a.option_strings and a.nargs is None]
    assert sub.parse_args(positional + ["--json"]).json is True


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_every_builder_builds(name):
    qc = build_circuit(name, 4)
    assert qc.num_parameters == 0
    # --size is the number of layers for the single-qubit re-uploading model
    assert qc.num_qubits == 1 if name == "reuploading" else qc.num_qubits >= 4


def test_build_draw_and_qasm(tmp_path, capsys):
    from qiskit import qasm2, qasm3
    from qiskit.quantum_info import Operator

    path = tmp_path / "rr.qasm"
    assert main(["build", "round_robin", "--size", "4", "--qasm", str(path)]) == 0
    assert path.read_text().startswith("OPENQASM 3.0")  # 3 by default, as everywhere else
    loaded = qasm3.loads(path.read_text())
    assert Operator(loaded).equiv(Operator(build_circuit("round_robin", 4)))
    path2 = tmp_path / "rr2.qasm"
    assert main(["build", "round_robin", "--size", "4", "--qasm", str(path2),
                 "--qasm-version", "2"]) == 0
    loaded = qasm2.loads(path2.read_text())
    assert Operator(loaded).equiv(Operator(build_circuit("round_robin", 4)))
    capsys.readouterr()
    assert main(["build", "round_robin", "--unbound", "--qasm", "-", "--qasm-version", "2"]) == 2
    assert "OpenQASM 2 has no free parameters" in capsys.readouterr().err
    assert main(["build", "round_robin", "--unbound", "--qasm", "-"]) == 0
    assert "input float[64]" in capsys.readouterr().out  # free parameters kept as inputs
    assert main(["build", "pyramid", "--size", "3", "--draw"]) == 0
    assert "Rbs" in capsys.readouterr().out


def test_unknown_builder_lists_known(capsys):
    assert main(["build", "nonsense"]) == 2
    err = capsys.readouterr().err
    assert "unknown builder 'nonsense'" in err and "round_robin" in err


def test_transpile_json(capsys):
    assert main(["transpile", "round_robin", "--size", "4", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["two_qubit_count"] == 2 * 6  # two CZ per RBS (docs/design.md, "Measured facts")
    assert main(["transpile", "round_robin", "--target", "nowhere"]) == 2
    assert "heavy_hex" in capsys.readouterr().err


def test_table1_json(capsys):
    assert main(["table1", "--n", "4", "8", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    rr = [r for r in rows if r["ansatz"] == "round_robin"]
    assert [r["density"]["gradient_circuits"] for r in rr] == [3, 7]
    assert [r["original"]["gradient_circuits"] for r in rr] == [24, 112]
    assert {r["ansatz"] for r in rows} == {"hardware_efficient", "equivariant_xx", "pyramid",
                                           "butterfly", "round_robin"}
    for r in rows:
        assert set(r) >= {"ansatz", "n", "original", "density"}
        assert set(r["original"]) >= {"params", "gradient_circuits"}
        assert set(r["density"]) >= {"params", "gradient_circuits", "sub_unitaries"}


def test_run_estimates_within_error(capsys):
    assert main(["run", "--size", "4", "--target", "ideal", "--shots", "4000", "--scheduler",
                 "proportional", "--json", "--seed", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["shots_used"] <= 4000 and out["pilot_allocation"] is None
    assert sum(out["allocation"]) == 4000
    z = abs(out["estimate"] - out["exact_noiseless"]) / out["standard_error"]
    assert z < 4.5


def test_run_budget_too_small(capsys):
    assert main(["run", "--size", "4", "--shots", "2", "--scheduler", "proportional"]) == 2
    assert "smaller" in capsys.readouterr().err


def test_run_neyman_json_separates_the_pilot(capsys):
    assert main(["run", "--size", "4", "--target", "ideal", "--shots", "600", "--scheduler",
                 "neyman", "--json", "--seed", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sum(out["allocation"]) + sum(out["pilot_allocation"]) == out["shots_used"] == 600
    assert len(out["per_subunitary"]) == len(out["allocation"]) == 3


def test_build_json_matches_the_circuit(tmp_path, capsys):
    qc = build_circuit("round_robin", 4)
    assert main(["build", "round_robin", "--size", "4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["num_qubits"] == 4 and out["num_parameters"] == 0
    assert out["count_ops"]["rbs"] == 6 == 4 * 3 // 2  # round robin: n(n-1)/2 RBS gates
    assert (out["size"], out["depth"]) == (qc.size(), qc.depth())
    path = tmp_path / "rr.qasm"
    assert main(["build", "round_robin", "--size", "4", "--qasm", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["qasm_file"] == str(path) and path.read_text().startswith("OPENQASM 3.0")


def test_export_check_is_current(capsys):
    assert main(["export", "circuits", "--check"]) == 0
    assert "current" in capsys.readouterr().out
    assert main(["export", "circuits", "--check", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {"directory": "circuits", "check": True,
                                                   "stale": []}


def test_export_json_lists_the_written_files(tmp_path, capsys):
    assert main(["export", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["paths"]) == sorted(str(p) for p in tmp_path.iterdir())
    assert any(p.endswith("README.md") for p in out["paths"]) and len(out["paths"]) > 10


def test_demo_quick_json(tmp_path, capsys):
    """``qdensity demo --quick --json``: the demo's code path at 4 qubits (seconds)."""
    from qdensity.demo import DemoConfig

    assert main(["demo", "--quick", "--json", "--output", str(tmp_path)]) == 0
    res = json.loads(capsys.readouterr().out)
    cfg = DemoConfig.quick()
    per_point = {"pure": 4 * 6 + 1, "density": 3 + 3}
    for name in ("pure", "density"):
        r = res[name]
        assert 0 < r["shots"] <= cfg.budget
        assert 0.0 <= r["accuracy"] <= 1.0 and 0.0 <= r["ceiling"] <= 1.0
        assert r["fraction_of_ceiling"] == pytest.approx(r["accuracy"] / r["ceiling"])
        # every step samples batch x per-point circuits at cfg.shots each; one more step would
        # have crossed the budget
        step_shots = cfg.batch_size * per_point[name] * cfg.shots
        assert r["shots"] == r["steps"] * step_shots == r["circuits"] * cfg.shots
        assert r["shots"] + step_shots > cfg.budget
    # per data point on 4 qubits: 4 x 6 shift + 1 forward = 25 circuits for the pure model,
    # 3 forward + 3 commuting = 6 for the density model: ~4x more steps for the same shots
    assert res["density"]["steps"] >= 3 * res["pure"]["steps"]
    assert res["config"]["budget"] == cfg.budget and res["config"]["seed"] == 7
    # --quick writes its own file, never the full demo's qdensity-demo.png
    assert (tmp_path / "qdensity-demo-quick.png").stat().st_size > 1000
    assert not (tmp_path / "qdensity-demo.png").exists()
    assert res["plot"] == str((tmp_path / "qdensity-demo-quick.png").resolve())
    assert np.isfinite(res["density"]["curve"][-1][1])


# ------------------------------------------------------------------ first hour: messages
def test_version_and_help_shows_defaults(capsys):
    from qdensity import __version__

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.strip() == f"qdensity {__version__}"
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "(default: 7)" in out and "(default: 32000; 2400 with --quick)" in out
    assert "(default: None)" not in out


def test_build_size_and_qasm_folder_messages(capsys, tmp_path):
    assert main(["build", "pyramid", "--size", "-3"]) == 2
    assert "--size must be an int in [2, 64] for pyramid, got -3" in capsys.readouterr().err
    assert main(["build", "butterfly", "--size", "6"]) == 2
    assert "a power of two for butterfly" in capsys.readouterr().err
    missing = tmp_path / "no" / "such" / "c.qasm"
    assert main(["build", "pyramid", "--qasm", str(missing)]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "Errno" not in err


def test_built_circuits_have_stable_names():
    from qdensity.cli.main import build_circuit

    for name in ("pyramid", "deterministic", "commuting_gradient", "hardware_efficient"):
        assert build_circuit(name, 4).name == build_circuit(name, 4).name == f"{name}_4"


def test_table1_says_why_the_butterfly_row_is_dropped(capsys):
    assert main(["table1", "--n", "3", "--ansatz", "butterfly", "pyramid"]) == 0
    captured = capsys.readouterr()
    assert "butterfly row is dropped for n = 3" in captured.err
    assert "butterfly" not in captured.out


def test_demo_refuses_a_budget_below_one_step_before_training(capsys, tmp_path):
    assert main(["demo", "--quick", "--budget", "1", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "budget=1 shots cannot pay for one training step" in err
    assert not list(tmp_path.iterdir())
