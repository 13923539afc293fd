"""Resource reports against counts worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector

from qdensity.circuits.gates import RBSGate
from qdensity.hardware.resources import (
    METRICS,
    ResourceReport,
    compare_reports,
    resource_report,
)
from qdensity.hardware.targets import HardwareTarget, get_target


def test_three_czs_in_sequence():
    qc = QuantumCircuit(2, name="seq")
    for _ in range(3):
        qc.cz(0, 1)
    rep = resource_report(qc, transpiled=True)
    assert (rep.num_qubits, rep.depth, rep.two_qubit_count, rep.two_qubit_depth) == (2, 3, 3, 3)
    assert rep.gate_counts == {"cz": 3}
    assert rep.name == "seq"


def test_parallel_czs_have_depth_one():
    qc = QuantumCircuit(4)
    qc.cz(0, 1)
    qc.cz(2, 3)
    for transpiled in (True, False):
        rep = resource_report(qc, transpiled=transpiled)
        assert (rep.depth, rep.two_qubit_count, rep.two_qubit_depth) == (1, 2, 1)
        assert rep.num_qubits == 4


def test_mixed_circuit_by_hand():
    # q0: sx | cz(0,1) | rz ; q1: . | cz(0,1) | cz(1,2) ; q2: x | . | cz(1,2) ; q3 idle
    qc = QuantumCircuit(4)
    qc.sx(0)
    qc.x(2)
    qc.cz(0, 1)
    qc.barrier()
    qc.cz(1, 2)
    qc.rz(0.3, 0)
    rep = resource_report(qc, transpiled=True)
    assert rep.num_qubits == 3  # qubit 3 is never touched
    assert rep.depth == 3
    assert rep.two_qubit_count == 2
    assert rep.two_qubit_depth == 2
    assert rep.gate_counts == {"cz": 2, "rz": 1, "sx": 1, "x": 1}
    assert rep.target == "ideal[cz,rz,sx,x]"


def test_measurements_count_in_depth_but_not_as_two_qubit_gates():
    qc = QuantumCircuit(2)
    qc.cz(0, 1)
    qc.measure_all()
    rep = resource_report(qc, transpiled=True)
    assert rep.depth == 2 and rep.two_qubit_count == 1 and rep.two_qubit_depth == 1
    assert rep.gate_counts == {"cz": 1, "measure": 2}


def _rbs_brick(n: int, layers: int) -> tuple[QuantumCircuit, int]:
    theta = ParameterVector("theta", layers * (n - 1))
    qc = QuantumCircuit(n)
    qc.x(0)
    k = 0
    for layer in range(layers):
        for i in range(layer % 2, n - 1, 2):
            qc.append(RBSGate(theta[k]), [i, i + 1])
            k += 1
    return qc, k


def test_rbs_costs_two_cz_on_ideal_and_one_native_gate_on_rbs_native():
    qc, num_rbs = _rbs_brick(4, 4)
    ideal = resource_report(qc)
    assert ideal.two_qubit_count == 2 * num_rbs  # docs/design.md, "Measured facts": 2 CZ per RBS
    assert ideal.gate_counts["cz"] == 2 * num_rbs
    native = resource_report(qc, "rbs_native")
    assert native.two_qubit_count == num_rbs
    assert native.gate_counts["xx_plus_yy"] == num_rbs
    # the brick's 2q-depth is its number of RBS layers on the native device, twice that on CZ
    assert native.two_qubit_depth == 4
    assert ideal.two_qubit_depth == 8


def test_non_adjacent_gates_on_a_line_need_swaps():
    # a star K_{1,3} is not a subgraph of a path: routing must add two-qubit gates
    qc = QuantumCircuit(4)
    qc.cx(0, 1)
    qc.cx(0, 2)
    qc.cx(0, 3)
    ideal = resource_report(qc)
    full = resource_report(qc, "all_to_all")
    line = resource_report(qc, "line")
    assert ideal.two_qubit_count == 3
    assert full.two_qubit_count == 3
    assert line.two_qubit_count > 3
    assert line.num_qubits == 4


def test_transpiles_exactly_once_per_report(monkeypatch):
    calls = []
    original = HardwareTarget.transpile

    def counting(self, circuits, *args, **kwargs):
        calls.append(self.name)
        return original(self, circuits, *args, **kwargs)

    monkeypatch.setattr(HardwareTarget, "transpile", counting)
    qc, _ = _rbs_brick(3, 2)
    resource_report(qc, "line")
    assert calls == ["line"]
    resource_report(qc)
    assert calls == ["line", "ideal"]
    resource_report(qc.decompose(), get_target("ring", 3), transpiled=True)
    assert calls == ["line", "ideal"]


def test_reports_are_reproducible():
    rng = np.random.default_rng(0)
    qc = QuantumCircuit(5)
    for _ in range(12):
        i, j = rng.choice(5, size=2, replace=False)
        qc.cx(int(i), int(j))
    a = resource_report(qc, "heavy_hex", optimization_level=2, seed=4)
    b = resource_report(qc, "heavy_hex", optimization_level=2, seed=4)
    assert a == b
    assert a.target == "heavy_hex"


def test_table_as_dict_and_str():
    qc = QuantumCircuit(2, name="pair")
    qc.sx(0)
    qc.cz(0, 1)
    rep = resource_report(qc, transpiled=True)
    text = rep.table()
    assert str(rep) == text
    for metric in METRICS:
        assert metric in text
    assert "gates[cz]" in text and "gates[sx]" in text
    assert text.splitlines()[0] == "pair on ideal[cz,rz,sx,x]"
    assert rep.as_dict() == {
        "name": "pair", "target": "ideal[cz,rz,sx,x]", "num_qubits": 2, "depth": 2,
        "two_qubit_count": 1, "two_qubit_depth": 1, "gate_counts": {"cz": 1, "sx": 1},
    }


def test_compare_reports_layout_and_ratios():
    a = ResourceReport("c", "ideal", 4, 10, 8, 4, {"cz": 8, "rz": 3})
    b = ResourceReport("c", "line", 4, 25, 20, 10, {"cx": 20})
    text = compare_reports({"ideal": a, "line": b})
    lines = text.splitlines()
    assert lines[0].split() == ["metric", "ideal", "line", "line/ideal"]
    rows = {ln.split()[0]: ln.split()[1:] for ln in lines[2:]}
    assert rows["num_qubits"] == ["4", "4", "1.00"]
    assert rows["depth"] == ["10", "25", "2.50"]
    assert rows["two_qubit_count"] == ["8", "20", "2.50"]
    assert rows["two_qubit_depth"] == ["4", "10", "2.50"]
    assert rows["gates[cx]"] == ["0", "20", "inf"]
    assert rows["gates[cz]"] == ["8", "0", "0.00"]
    assert rows["gates[rz]"] == ["3", "0", "0.00"]
    assert len({len(ln) for ln in lines[:2]}) == 1  # header and rule line up
    zero = ResourceReport("z", "ideal", 1, 1, 0, 0, {})
    assert compare_reports({"a": zero, "b": zero}).splitlines()[4].split()[-1] == "n/a"
    assert compare_reports({"only": a}).splitlines()[0].split() == ["metric", "only"]


def test_bad_inputs():
    with pytest.raises(TypeError, match="circuit"):
        resource_report("qc")
    with pytest.raises(TypeError, match="target"):
        resource_report(QuantumCircuit(2), target=3)
    with pytest.raises(ValueError, match="known targets"):
        resource_report(QuantumCircuit(2), target="grid")
    with pytest.raises(ValueError, match="optimization_level"):
        resource_report(QuantumCircuit(2), optimization_level=7)
    with pytest.raises(ValueError, match="at least one"):
        compare_reports({})
    with pytest.raises(TypeError, match="ResourceReport"):
        compare_reports({"a": 1})
