"""``--target`` takes a snapshot file; ``run`` takes ``--mitigation`` / ``--postselect``."""

import json

import pytest
from qiskit_ibm_runtime.fake_provider import FakeManilaV2

from qdensity.cli import main
from qdensity.hardware.snapshot_files import save_snapshot


def test_transpile_on_a_snapshot_file(tmp_path, capsys):
    path = save_snapshot(FakeManilaV2(), tmp_path / "manila.json")
    assert main(["transpile", "pyramid", "--size", "4", "--target", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["target"] == "fake_manila"
    assert set(out["gate_counts"]) <= set(FakeManilaV2().operation_names)
    assert main(["transpile", "pyramid", "--size", "6", "--target", str(path)]) == 2
    assert "has 6 qubits but target 'fake_manila' has 5" in capsys.readouterr().err


def test_run_with_mitigation_and_postselection_on_a_device(tmp_path, capsys):
    args = ["run", "--size", "4", "--target", "fake_manila", "--shots", "3000", "--scheduler",
            "proportional", "--json", "--seed", "3"]
    assert main(args + ["--mitigation", "m3", "--postselect", "hamming_weight"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sum(out["allocation"]) == 3000
    # gate noise remains after the corrections: a loose check of the estimate
    assert abs(out["estimate"] - out["exact_noiseless"]) < 0.2
    with pytest.raises(SystemExit):
        main(args + ["--mitigation", "zne"])
    assert "invalid choice: 'zne' (choose from 'm3')" in capsys.readouterr().err
