"""The ``noise`` experiment on a device pinned by a snapshot file (issue 25: ``--set
target=PATH``): the file reproduces the device it was saved from bit for bit, the JSON config
keeps the path and each seed records the device it ran on; bad files are refused by name."""

import json

import pytest

from qdensity.hardware import get_target, save_snapshot
from qdensity_paper import noise, run
from qdensity_paper.cli.experiment import _setting

TINY = {"num_qubits": 3, "classes": 3, "train_size": 40, "test_size": 6, "shots": 4,
        "budget": 240, "batch_size": 2, "checkpoints": 2, "eval_shots": 12,
        "eval_shots_sweep": [6, 48], "calibration_shots": 100, "ceiling_epochs": 0,
        "mitigation": False}


def test_noise_on_a_snapshot_file_equals_the_device_it_was_saved_from(tmp_path):
    # run_seed builds heavy_hex for 3 qubits from the seed; the file of that very backend must
    # give the same training, scores and curves (the oracle: the named device itself)
    seed = 1
    path = save_snapshot(get_target("heavy_hex", TINY["num_qubits"], seed=seed).backend,
                         tmp_path / "device.json")
    assert _setting(f"target={path}") == ("target", str(path))  # --set keeps the path text
    result = run("noise", config=dict(TINY, target=str(path)), seeds=[seed], out=tmp_path,
                 plot=False, progress=False)
    saved = json.loads((tmp_path / "noise-quick.json").read_text())
    assert saved["config"]["target"] == str(path)
    from_file = result.per_seed[0]
    assert from_file["device"] == "generic_backend_19q" and from_file["device_qubits"] == 19
    named = noise.run_seed(dict(noise.QUICK, **TINY, target="heavy_hex"), seed, False)
    assert named["device"] == "heavy_hex"
    for out in (from_file, named):  # what the runner adds about the process, and the name
        for key in ("device", "seconds", "worker"):
            out.pop(key, None)
    assert json.dumps(from_file, sort_keys=True) == json.dumps(named, sort_keys=True)


def test_noise_refuses_a_bad_snapshot_file_by_setting(tmp_path):
    missing = tmp_path / "missing.json"
    with pytest.raises(ValueError, match=r"setting 'target'.*existing file.*missing\.json"):
        noise.check_config(dict(noise.QUICK, target=str(missing)))
    foreign = tmp_path / "other.json"
    foreign.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(ValueError, match=r"setting 'target'.*not a qdensity device snapshot"):
        noise.check_config(dict(noise.QUICK, target=str(foreign)))
    with pytest.raises(ValueError, match=r"setting 'target'.*save_snapshot"):
        noise.check_config(dict(noise.QUICK, target=3))
