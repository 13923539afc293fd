"""The ``qdensity`` command: every sub-command, JSON outputs against independent numbers,
bad input gives a message and exit status 2; the demo at a tiny budget."""

import json

import numpy as np
import pytest

from qdensity.cli import BUILDERS, build_circuit, main


def test_help_everywhere(capsys):
    for argv in (["--help"], ["build", "--help"], ["transpile", "--help"], ["run", "--help"],
                 ["table1", "--help"], ["export", "--help"], ["demo", "--help"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0
    assert "usage" in capsys.readouterr().out


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_every_builder_builds(name):
    qc = build_circuit(name, 4)
    assert qc.num_parameters == 0
    # --size is the number of layers for the single-qubit re-uploading model
    assert qc.num_qubits == 1 if name == "reuploading" else qc.num_qubits >= 4


def test_build_draw_and_qasm(tmp_path, capsys):
    path = tmp_path / "rr.qasm"
    assert main(["build", "round_robin", "--size", "4", "--qasm", str(path)]) == 0
    from qiskit import qasm2
    from qiskit.quantum_info import Operator

    loaded = qasm2.loads(path.read_text())
    assert Operator(loaded).equiv(Operator(build_circuit("round_robin", 4)))
    assert main(["build", "pyramid", "--size", "3", "--draw"]) == 0
    assert "Rbs" in capsys.readouterr().out


def test_unknown_builder_lists_known(capsys):
    assert main(["build", "nonsense"]) == 2
    err = capsys.readouterr().err
    assert "unknown builder 'nonsense'" in err and "round_robin" in err


def test_transpile_json(capsys):
    assert main(["transpile", "round_robin", "--size", "4", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["two_qubit_count"] == 2 * 6  # two CZ per RBS (DESIGN.md)
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
    assert out["shots_spent"] <= 4000
    assert sum(out["allocation"]) == 4000
    z = abs(out["estimate"] - out["exact_noiseless"]) / out["standard_error"]
    assert z < 4.5


def test_run_budget_too_small(capsys):
    assert main(["run", "--size", "4", "--shots", "2", "--scheduler", "proportional"]) == 2
    assert "smaller" in capsys.readouterr().err


def test_export_check_is_current():
    assert main(["export", "circuits", "--check"]) == 0


def test_demo_tiny(tmp_path):
    from qdensity.experiments.demo import DemoConfig, run_demo

    cfg = DemoConfig(budget=8000, shots=16, batch_size=2, test_size=100, eval_every=2)
    res = run_demo(cfg, output_dir=tmp_path, verbose=False)
    for name in ("pure", "density"):
        assert res[name]["shots"] <= cfg.budget
        assert 0.0 <= res[name]["accuracy"] <= 1.0
    # the density model takes ~8x more steps for the same shots (7+7 vs 112+1 circuits/point)
    assert res["density"]["steps"] > 4 * res["pure"]["steps"]
    assert (tmp_path / "qdensity-demo.png").stat().st_size > 1000
    assert np.isfinite(res["density"]["curve"][-1][1])
