"""Snapshot files edited by hand are refused before anything is built, naming the file, the
field and the qubit; what ``save_snapshot`` writes ``get_target`` reads back; the CLI prints one
line and exits 2.

Oracles: the physical ranges (errors in [0, 1], T1 > 0, 0 < T2 <= 2 T1, durations >= 0), the
device's width and each gate's arity from qiskit's standard gates; qiskit-aer's own
``NoiseModel.from_backend`` of the original device for the round trips.
"""

from __future__ import annotations

import json
import math

import pytest
from qiskit.circuit.library import CXGate, Measure, XGate
from qiskit.transpiler import InstructionProperties, Target
from qiskit_aer.noise import NoiseModel
from qiskit_ibm_runtime.fake_provider import FakeManilaV2, FakeTorino

from qdensity.cli import main
from qdensity.hardware import get_target, load_snapshot, save_snapshot


@pytest.fixture(scope="module")
def manila(tmp_path_factory):
    path = save_snapshot(FakeManilaV2(), tmp_path_factory.mktemp("snap") / "manila.json")
    return json.loads(path.read_text())


def _entry(data, op, qargs):
    return next(e for e in data["instructions"][op] if e["qubits"] == qargs)


def _edit(data, how):
    data = json.loads(json.dumps(data))
    kind, value = how
    if kind == "readout":
        _entry(data, "measure", [2])["error"] = value
    elif kind == "cx":
        data["instructions"]["cx"][0]["error"] = value
    elif kind == "t1":
        data["qubits"][3]["t1"] = value
    elif kind == "t2":
        data["qubits"][3]["t2"] = value
    elif kind == "duration":
        _entry(data, "sx", [1])["duration"] = value
    elif kind == "qubit":
        data["instructions"]["x"][0]["qubits"] = [value]
    elif kind == "arity":
        data["instructions"]["cx"][0]["qubits"] = value
    elif kind == "num_qubits":
        data["num_qubits"] = value
    elif kind == "frequency":
        data["qubits"][1]["frequency"] = value
    elif kind == "dt":
        data["dt"] = value
    return data


CASES = [
    (("readout", math.nan), r"measure\[\d+\]\.error \(qubit 2\).*\[0, 1\]|error.*qubit 2"),
    (("readout", 1.7), r"measure\[\d+\]\.error \(qubit 2\).*<= 1"),
    (("readout", -0.1), r"measure\[\d+\]\.error \(qubit 2\)"),
    (("cx", 1.5), r"instructions\.cx\[0\]\.error \(qubit \(\d, \d\)\)"),
    (("cx", -0.2), r"instructions\.cx\[0\]\.error"),
    (("cx", "0.1"), r"instructions\.cx\[0\]\.error"),
    (("t1", -5e-5), r"qubits\[3\]\.t1 \(qubit 3\).*> 0"),
    (("t1", 0.0), r"qubits\[3\]\.t1 \(qubit 3\)"),
    (("t1", math.nan), r"qubits\[3\]\.t1 \(qubit 3\)"),
    (("t1", math.inf), r"qubits\[3\]\.t1 \(qubit 3\)"),
    (("t2", 1.0), r"qubits\[3\]\.t2 \(qubit 3\).*2 \* t1"),
    (("t2", 0.0), r"qubits\[3\]\.t2 \(qubit 3\)"),
    (("duration", -1e-9), r"instructions\.sx\[\d+\]\.duration \(qubit 1\)"),
    (("qubit", 9), r"instructions\.x\[0\]\.qubits \(qubit 9\).*\[0, 4\]"),
    (("qubit", -1), r"instructions\.x\[0\]\.qubits \(qubit -1\)"),
    (("arity", [0, 1, 2]), r"instructions\.cx\[0\]\.qubits.*2 qubit indices.*'cx' acts on 2"),
    (("arity", [1, 1]), r"instructions\.cx\[0\]\.qubits.*distinct"),
    (("num_qubits", -2), r"num_qubits must be an int in \[1, 4096\], got -2"),
    (("num_qubits", 2.5), r"num_qubits must be an int"),
    (("frequency", -1.0), r"qubits\[1\]\.frequency \(qubit 1\)"),
    (("dt", 0.0), r"dt must be None or a finite number > 0"),
]


@pytest.mark.parametrize("how, message", CASES, ids=[f"{k}={v}" for (k, v), _ in CASES])
def test_hand_edited_snapshot_is_refused_naming_file_field_and_qubit(manila, tmp_path, how,
                                                                     message):
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(_edit(manila, how)))
    with pytest.raises(ValueError, match=message) as info:
        load_snapshot(path)
    assert "edited.json" in str(info.value)


def test_deep_nesting_is_a_clear_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(ValueError, match="deep.json.*nested deeper"):
        load_snapshot(path)
    shallow = tmp_path / "shallow.json"
    shallow.write_text(json.dumps({"format": "qdensity-device-snapshot", "version": 1,
                                   "name": [[[[["x"]]]]], "num_qubits": 2,
                                   "instructions": {}}))
    with pytest.raises(ValueError, match="shallow.json': name must be a non-empty str"):
        load_snapshot(shallow)


@pytest.mark.parametrize("how", [("t1", -5e-5), ("readout", math.nan), ("readout", 1.7),
                                 ("qubit", 9), ("num_qubits", -2), ("arity", [0, 1, 2])],
                         ids=str)
def test_cli_prints_one_line_and_exits_2(manila, tmp_path, capsys, how):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(_edit(manila, how)))
    code = main(["transpile", "pyramid", "--size", "4", "--target", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and "bad.json" in err
    deep = tmp_path / "deep.json"
    deep.write_text("{\"a\":" * 200_000 + "1" + "}" * 200_000)
    assert main(["transpile", "pyramid", "--size", "4", "--target", str(deep)]) == 2
    assert "nested deeper" in capsys.readouterr().err


def test_device_without_qubit_properties_round_trips(tmp_path):
    t = Target(num_qubits=2)
    t.add_instruction(CXGate(), {(0, 1): InstructionProperties(error=0.01, duration=1e-7)})
    t.add_instruction(XGate(), {(0,): InstructionProperties(error=0.001), (1,): None})
    t.add_instruction(Measure(), {(0,): InstructionProperties(error=0.02),
                                  (1,): InstructionProperties(error=0.03)})
    path = save_snapshot(t, tmp_path / "bare.json")
    tgt = get_target(str(path))
    assert tgt.num_qubits == 2
    assert tgt.target["cx"][(0, 1)].error == 0.01
    assert tgt.target["measure"][(1,)].error == 0.03
    noise = tgt.noise_model.to_dict()
    assert noise["errors"]  # the calibrated errors became noise


def test_t2_above_twice_t1_is_saved_as_aers_noise_reads_it(tmp_path):
    backend = FakeTorino()
    over = [q for q, p in enumerate(backend.target.qubit_properties)
            if p.t1 is not None and p.t2 is not None and p.t2 > 2 * p.t1]
    assert over  # the device reports some (measurement noise)
    path = save_snapshot(backend, tmp_path / "torino.json")
    back = load_snapshot(path).target.qubit_properties
    for q in over:
        assert back[q].t2 == 2 * backend.target.qubit_properties[q].t1
    # the noise model is the same: qiskit-aer truncates T2 to 2 T1 itself
    qs = over[:1]
    ours = NoiseModel.from_backend(load_snapshot(path)).to_dict()
    theirs = NoiseModel.from_backend(backend).to_dict()
    pick = [e for e in ours["errors"] if e["operations"] == ["sx"] and e["gate_qubits"] == [qs]]
    ref = [e for e in theirs["errors"] if e["operations"] == ["sx"] and e["gate_qubits"] == [qs]]
    assert json.dumps(pick, sort_keys=True, default=str) == json.dumps(ref, sort_keys=True,
                                                                       default=str)


def test_save_refuses_a_device_it_could_not_read_back(tmp_path):
    t = Target(num_qubits=2)
    t.add_instruction(XGate(), {(0,): InstructionProperties(error=1.5), (1,): None})
    with pytest.raises(ValueError, match=r"instructions\.x\[0\]\.error \(qubit 0\)"):
        save_snapshot(t, tmp_path / "x.json")
    assert not (tmp_path / "x.json").exists()
