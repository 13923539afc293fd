"""Exported reference circuits (``circuits/``): current, complete, and reloading equivalently.

Oracles: the builders' own circuits evaluated by ``qiskit.quantum_info.Operator`` (RBS and FBS
through their matrices, not their definitions), the loaders' defining amplitudes
``x / ||x||`` and ``sqrt(alpha)``, and the files on disk as ``qiskit.qasm2`` reads them.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from qiskit import QuantumCircuit, qasm2, transpile
from qiskit.circuit import Parameter
from qiskit.quantum_info import Operator, Statevector
from qiskit_aer import AerSimulator

from qdensity.cli.export import (
    INDEX_NAME,
    QASM2_BASIS,
    REFERENCE_BUILDERS,
    bind_reference,
    check_circuits,
    export_circuits,
    main,
    reference_seed,
)

CIRCUITS = Path(__file__).resolve().parents[2] / "circuits"
NAMES = list(REFERENCE_BUILDERS)
MAX_OPERATOR_QUBITS = 8


def _load(name: str) -> QuantumCircuit:
    return qasm2.loads((CIRCUITS / f"{name}.qasm").read_text(encoding="utf-8"))


def _measure_map(circuit: QuantumCircuit) -> set[tuple[int, int]]:
    return {
        (circuit.find_bit(inst.qubits[0]).index, circuit.find_bit(inst.clbits[0]).index)
        for inst in circuit.data
        if inst.operation.name == "measure"
    }


def _index_rows() -> dict[str, list[str]]:
    rows = {}
    for line in (CIRCUITS / INDEX_NAME).read_text(encoding="utf-8").splitlines():
        match = re.match(r"\| \[`([\w.]+)\.qasm`\]\(([\w.]+)\.qasm\) \|(.*)\|$", line)
        if match:
            assert match.group(1) == match.group(2), line
            rows[match.group(1)] = [cell.strip() for cell in match.group(3).split("|")]
    return rows


# ------------------------------------------------------------------ the repository's files


def test_repository_circuits_are_current():
    assert CIRCUITS.is_dir(), f"{CIRCUITS} missing: run `python -m qdensity.cli.export`"
    assert check_circuits(CIRCUITS) == []


def test_every_reference_name_has_a_file_and_nothing_else():
    on_disk = {p.stem for p in CIRCUITS.glob("*.qasm")}
    assert on_disk == set(NAMES)
    assert len(NAMES) >= 23


@pytest.mark.parametrize("name", NAMES)
def test_file_reloads_to_the_builders_operator(name):
    built = REFERENCE_BUILDERS[name]()
    assert built.num_parameters == 0, "reference circuits have bound parameters"
    loaded = _load(name)
    assert loaded.num_qubits == built.num_qubits <= MAX_OPERATOR_QUBITS
    assert [(r.name, r.size) for r in loaded.qregs] == [(r.name, r.size) for r in built.qregs]
    # Measurements are kept, on the same qubit -> clbit pairs.
    assert _measure_map(loaded) == _measure_map(built)
    expected = Operator(built.remove_final_measurements(inplace=False))
    actual = Operator(loaded.remove_final_measurements(inplace=False))
    assert actual.equiv(expected, atol=1e-9)


@pytest.mark.parametrize("name", NAMES)
def test_file_holds_only_qelib1_gates(name):
    text = (CIRCUITS / f"{name}.qasm").read_text(encoding="utf-8")
    assert text.startswith("OPENQASM 2.0;\n")
    assert 'include "qelib1.inc";' in text
    assert not re.search(r"^\s*(gate|opaque)\s", text, re.MULTILINE), "no custom gate definitions"
    ops = set(_load(name).count_ops())
    assert ops <= set(QASM2_BASIS) | {"measure", "barrier"}


def test_index_lists_every_file_with_its_width():
    rows = _index_rows()
    assert set(rows) == {p.stem for p in CIRCUITS.glob("*.qasm")}
    for name, (qubits, two_qubit, depth, description, qasm3) in rows.items():
        loaded = _load(name)
        assert int(qubits) == loaded.num_qubits
        gates = sum(
            1 for inst in loaded.data
            if len(inst.qubits) == 2 and inst.operation.name not in ("barrier", "measure")
        )
        assert int(two_qubit) == gates
        assert int(depth) >= 1 and description
        assert qasm3.startswith(f"[`{name}.qasm3`]({name}.qasm3) (")
    text = (CIRCUITS / INDEX_NAME).read_text(encoding="utf-8")
    assert "python -m qdensity.cli.export" in text and "qdensity export" in text


@pytest.mark.parametrize(
    ("name", "amplitudes"),
    [
        ("loader_parallel_5", [0.8, -0.3, 0.0, 0.5, -1.1]),
        ("loader_diagonal_5", [0.8, -0.3, 0.0, 0.5, -1.1]),
        ("loader_semi_diagonal_5", [0.8, -0.3, 0.0, 0.5, -1.1]),
        ("load_sqrt_alpha_4", np.sqrt([0.4, 0.3, 0.2, 0.1])),
    ],
)
def test_loader_files_prepare_the_defined_state(name, amplitudes):
    amplitudes = np.asarray(amplitudes, dtype=float)
    target = np.zeros(2 ** amplitudes.size, dtype=complex)
    target[2 ** np.arange(amplitudes.size)] = amplitudes / np.linalg.norm(amplitudes)
    state = Statevector(_load(name)).data
    overlap = np.vdot(target, state)
    assert abs(abs(overlap) - 1.0) < 1e-10
    assert np.allclose(state * np.conj(overlap), target, atol=1e-10)


def test_matrix_loader_file_prepares_the_normalised_matrix():
    X = np.array([[1.0, -2.0, 0.5], [0.0, 0.7, -1.2]])
    target = np.zeros(2**5, dtype=complex)
    for i in range(2):
        for j in range(3):
            target[2**i + 2 ** (2 + j)] = X[i, j] / np.linalg.norm(X)
    state = Statevector(_load("matrix_loader_2x3")).data
    overlap = np.vdot(target, state)
    assert abs(abs(overlap) - 1.0) < 1e-10


@pytest.mark.parametrize("basis", [["cz", "rz", "sx", "x"], ["cx", "rz", "sx", "x"]])
def test_every_file_transpiles_to_hardware_bases(basis):
    allowed = set(basis) | {"measure", "barrier"}
    for name in NAMES:
        compiled = transpile(_load(name), basis_gates=basis, optimization_level=1)
        assert set(compiled.count_ops()) <= allowed, name


def test_measured_file_runs_on_aer_after_transpiling():
    # Tomography circuit 0 samples |y_j|^2 of the loader + pyramid state on unary outcomes.
    loaded = _load("tomography_0_4")
    probs = Statevector(loaded.remove_final_measurements(inplace=False)).probabilities()
    compiled = transpile(loaded, basis_gates=["cz", "rz", "sx", "x"], optimization_level=1)
    shots = 4000
    counts = AerSimulator(seed_simulator=7).run(compiled, shots=shots).result().get_counts()
    assert set(counts) <= {format(2**j, "04b") for j in range(4)}
    for j in range(4):
        p = probs[2**j]
        freq = counts.get(format(2**j, "04b"), 0) / shots
        assert abs(freq - p) <= 5 * np.sqrt(p * (1 - p) / shots) + 1e-12


# ------------------------------------------------------------------ export / check mechanics


def test_export_is_deterministic_and_checks_clean(tmp_path):
    first = export_circuits(tmp_path / "a")
    second = export_circuits(tmp_path / "b")
    assert [p.name for p in first] == ([f"{n}.qasm" for n in NAMES]
                                       + [f"{n}.qasm3" for n in NAMES] + [INDEX_NAME])
    for a, b in zip(first, second, strict=True):
        assert a.read_bytes() == b.read_bytes()
    assert check_circuits(tmp_path / "a") == []
    # The repository's files are byte-identical to a fresh export on this platform or differ
    # only in angle round-off (check_circuits above); here they should be the same names.
    assert {p.name for p in first} == {p.name for p in CIRCUITS.iterdir() if p.is_file()}


def test_check_reports_missing_changed_stale_and_index(tmp_path):
    export_circuits(tmp_path)
    (tmp_path / "pyramid_4.qasm").unlink()
    path = tmp_path / "butterfly_4.qasm"
    text = path.read_text(encoding="utf-8")
    angle = re.search(r"ry\((-?[\d.]+)\)", text).group(1)
    path.write_text(text.replace(angle, repr(float(angle) + 1e-3), 1), encoding="utf-8")
    (tmp_path / "old_circuit_9.qasm").write_text("OPENQASM 2.0;\n", encoding="utf-8")
    index = tmp_path / INDEX_NAME
    index.write_text(index.read_text(encoding="utf-8") + "edited\n", encoding="utf-8")
    assert check_circuits(tmp_path) == ["pyramid_4", "butterfly_4", "old_circuit_9", INDEX_NAME]


def test_check_tolerates_angle_round_off_only(tmp_path):
    export_circuits(tmp_path, NAMES)
    path = tmp_path / "round_robin_4.qasm"
    text = path.read_text(encoding="utf-8")
    angle = re.search(r"ry\((-?\d\.\d{8,})\)", text).group(1)
    nudged = repr(float(angle) * (1 + 4e-16) + 1e-16)
    assert nudged != angle
    path.write_text(text.replace(angle, nudged), encoding="utf-8")
    assert check_circuits(tmp_path) == []
    path.write_text(text.replace("cz q[0],q[1];", "cz q[1],q[0];", 1), encoding="utf-8")
    assert check_circuits(tmp_path) == ["round_robin_4"]


def test_export_subset_writes_its_own_index(tmp_path):
    paths = export_circuits(str(tmp_path), ["qcnn_4", "pyramid_4"])
    assert [p.name for p in paths] == ["qcnn_4.qasm", "pyramid_4.qasm", "qcnn_4.qasm3",
                                       "pyramid_4.qasm3", INDEX_NAME]
    index = (tmp_path / INDEX_NAME).read_text(encoding="utf-8")
    assert "qcnn_4.qasm" in index and "round_robin_4.qasm" not in index
    # A partial export is not a complete reference directory.
    assert "round_robin_4" in check_circuits(tmp_path)


def test_builders_are_reproducible_and_seeded_by_name():
    a, b = REFERENCE_BUILDERS["qcnn_4"](), REFERENCE_BUILDERS["qcnn_4"]()
    assert Operator(a).equiv(Operator(b), atol=0)
    assert reference_seed("pyramid_4") == reference_seed("pyramid_4")
    assert reference_seed("pyramid_4") != reference_seed("round_robin_4")
    qc = QuantumCircuit(1)
    qc.ry(Parameter("t"), 0)
    value = np.random.default_rng(reference_seed("demo")).uniform(-np.pi, np.pi, 1)[0]
    bound = bind_reference(qc, "demo")
    assert float(bound.data[0].operation.params[0]) == value
    assert -np.pi <= value < np.pi


def test_bad_input_is_refused(tmp_path):
    with pytest.raises(ValueError, match="'nope'"):
        export_circuits(tmp_path, ["nope"])
    with pytest.raises(TypeError, match="names"):
        export_circuits(tmp_path, "pyramid_4")
    with pytest.raises(TypeError, match="directory"):
        export_circuits(3)
    (tmp_path / "file").write_text("x", encoding="utf-8")
    with pytest.raises(ValueError, match="directory"):
        check_circuits(tmp_path / "file")
    with pytest.raises(ValueError, match="name"):
        reference_seed("")
    with pytest.raises(TypeError, match="name"):
        reference_seed(4)


def test_command_line(tmp_path, capsys):
    target = tmp_path / "out"
    assert main(["--check", str(target)]) == 2  # missing directory: named, not "out of date"
    assert "does not exist" in capsys.readouterr().err
    assert main([str(target)]) == 0
    assert main(["--check", str(target)]) == 0
    assert main(["--check", str(CIRCUITS)]) == 0
    assert "current" in capsys.readouterr().out
