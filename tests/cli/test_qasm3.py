"""OpenQASM 3 exports (``circuits/*.qasm3``): parameters symbolic, reloading to the builders.

Oracle: each builder's own circuit (RBS/FBS through their matrices, loaders as parameterised
templates), with the same random values bound, as ``qiskit.quantum_info.Operator``; the files
are read back with ``qiskit.qasm3.loads`` (``qiskit-qasm3-import``, in the dev extra).
"""

from __future__ import annotations

import re
import zlib
from pathlib import Path

import numpy as np
import pytest
from qiskit import qasm3
from qiskit.quantum_info import Operator

from qdensity.cli import main as cli_main
from qdensity.cli.export import REFERENCE_BUILDERS, check_circuits, export_circuits
from qdensity.cli.reference import QASM3_BASIS, _symbolic

CIRCUITS = Path(__file__).resolve().parents[2] / "circuits"
NAMES = list(REFERENCE_BUILDERS)
_INPUT = re.compile(r"^input float\[64\] (\S+);$", re.MULTILINE)


def _builder_circuit(name):
    """The builder's circuit with its parameters free (not the exported, unrolled form)."""
    with _symbolic():
        return REFERENCE_BUILDERS[name]()


@pytest.mark.parametrize("name", NAMES)
def test_qasm3_file_round_trips_with_symbolic_parameters(name):
    text = (CIRCUITS / f"{name}.qasm3").read_text(encoding="utf-8")
    assert text.startswith("OPENQASM 3.0;\n")
    built = _builder_circuit(name)
    declared = _INPUT.findall(text)
    assert len(declared) == built.num_parameters  # every trainable / data angle is an input
    loaded = qasm3.loads(text)
    assert loaded.num_parameters == built.num_parameters
    assert set(loaded.count_ops()) <= set(QASM3_BASIS) | {"measure", "barrier"}
    by_name = {p.name: p for p in loaded.parameters}
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for _ in range(2):
        values = rng.uniform(-np.pi, np.pi, built.num_parameters)
        want = built.assign_parameters(values).remove_final_measurements(inplace=False)
        got = loaded.assign_parameters(
            {by_name[d]: v for d, v in zip(declared, values, strict=True)}
        ).remove_final_measurements(inplace=False)
        assert Operator(got).equiv(Operator(want), atol=1e-9)


def test_trainable_and_data_parameters_are_kept():
    assert _INPUT.findall((CIRCUITS / "loader_parallel_5.qasm3").read_text())[0].startswith("_x")
    lcu = _INPUT.findall((CIRCUITS / "lcu_k3.qasm3").read_text())
    assert sum(d.startswith("_x") for d in lcu) == 3 and sum(d.startswith("_θ") for d in lcu) == 6
    assert _INPUT.findall((CIRCUITS / "load_sqrt_alpha_4.qasm3").read_text()) == []


def test_export_qasm3_command_and_check(tmp_path, capsys):
    out = tmp_path / "c"
    assert cli_main(["export", str(out), "--qasm3"]) == 0
    assert {p.suffix for p in out.iterdir()} == {".qasm3", ".md"}
    stale = check_circuits(out)
    assert stale == NAMES  # the OpenQASM 2 files are missing, the OpenQASM 3 ones current
    (out / "pyramid_4.qasm3").write_text("OPENQASM 3.0;\n", encoding="utf-8")
    (out / "gone_3.qasm3").write_text("OPENQASM 3.0;\n", encoding="utf-8")
    assert check_circuits(out)[len(NAMES):] == ["pyramid_4.qasm3", "gone_3.qasm3"]
    with pytest.raises(ValueError, match="formats"):
        export_circuits(out, formats=("qasm4",))
    with pytest.raises(ValueError, match="formats"):
        export_circuits(out, formats="qasm3")
