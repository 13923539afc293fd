"""The Aer method and options chosen per PUB (qdensity.hardware.aer_sampling): the documented
crossover table and the thread rule. The samplers that follow it:
tests/execution/test_aer_samplers.py."""

import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter

from qdensity.hardware import aer_sampling
from qdensity.hardware.aer_sampling import (
    DENSITY_MATRIX_MAX_QUBITS,
    FAST_SAMPLER_OPTIONS,
    active_qubits,
    aer_options,
)


def _ghz_ry(n: int) -> QuantumCircuit:
    theta = Parameter("t")
    qc = QuantumCircuit(n)
    qc.ry(theta, 0)
    for q in range(n - 1):
        qc.cx(q, q + 1)
    qc.measure_all()
    return qc


def test_active_qubits_ignore_idle_wires_and_barriers():
    qc = QuantumCircuit(19, 2)
    qc.barrier()
    qc.h(4)
    qc.cx(4, 11)
    qc.measure([4, 11], [0, 1])
    assert active_qubits(qc) == 2
    with pytest.raises(TypeError, match="circuit"):
        active_qubits("qc")


def test_rule_is_the_documented_crossover():
    # noisy: density matrix from the measured crossover (8 up to 4 active qubits, 16, 32, 96,
    # 64 at 5 to 8, 2 ** (a - 2) above), up to DENSITY_MATRIX_MAX_QUBITS active qubits
    table = {5: 16, 6: 32, 7: 96, 8: 64}
    for a in range(1, DENSITY_MATRIX_MAX_QUBITS + 3):
        at = 8 if a <= 4 else table.get(a, 2 ** (a - 2))
        expect = "density_matrix" if a <= DENSITY_MATRIX_MAX_QUBITS else "statevector"
        assert aer_options(a, at, True)["method"] == expect
        if at > 1:
            assert aer_options(a, at - 1, True)["method"] == "statevector"
    for opts in (aer_options(6, 16, True), aer_options(10, 64, True), aer_options(6, 99, False),
                 FAST_SAMPLER_OPTIONS):
        # shot branching with noise samples wrong distributions in qiskit-aer 0.18.2
        assert opts["shot_branching_enable"] is False
        assert opts["runtime_parameter_bind_enable"] is True
    assert aer_options(6, 16, True)["max_parallel_threads"] == 1
    assert aer_options(20, 10, False)["max_parallel_threads"] == 0
    with pytest.raises(ValueError, match="shots"):
        aer_options(3, 0, True)
    with pytest.raises(ValueError, match="rows"):
        aer_options(3, 10, True, rows=0)


def _threads(opts: dict) -> str:
    assert opts["method"] == "statevector"
    if opts["max_parallel_threads"] == 1:
        assert "max_parallel_shots" not in opts
        return "one"
    assert opts["max_parallel_threads"] == 0 and opts["max_parallel_shots"] == 0
    return "all"


def test_trajectories_spread_over_threads_only_for_large_calls_on_an_idle_machine(monkeypatch):
    # the module's rule: from 8 active qubits and PARALLEL_TRAJECTORIES trajectories a call
    # (rows x shots), or from 14 active qubits, and only while a core is idle
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: True)
    big = aer_sampling.PARALLEL_TRAJECTORIES
    assert _threads(aer_options(8, 16, True, rows=16)) == "one"  # 256 trajectories
    assert _threads(aer_options(10, 16, True, rows=16)) == "one"
    assert _threads(aer_options(12, 256, True, rows=big // 256 - 1)) == "one"
    assert _threads(aer_options(12, 256, True, rows=big // 256)) == "all"
    assert _threads(aer_options(7, 4, True, rows=big)) == "one"  # below 8 active qubits
    assert _threads(aer_options(8, 4, True, rows=big // 4)) == "all"
    assert _threads(aer_options(14, 1, True)) == "all"
    monkeypatch.setattr(aer_sampling, "idle_core", lambda: False)  # every core busy
    assert _threads(aer_options(12, 256, True, rows=big)) == "one"
    assert _threads(aer_options(14, 1, True)) == "one"
    monkeypatch.setattr(aer_sampling, "LOAD_AWARE", False)
    assert _threads(aer_options(14, 1, True)) == "all"


@pytest.mark.parametrize(("active", "shots", "method"), [
    # the benchmark grid's cells: at 4 active qubits a density-matrix row (~1 ms) costs a few
    # trajectories (~0.17 ms each), at 6 and 8 qubits 35-60 of them
    (4, 7, "statevector"), (4, 16, "density_matrix"), (4, 256, "density_matrix"),
    (6, 16, "statevector"), (6, 32, "density_matrix"),
    (8, 16, "statevector"), (8, 63, "statevector"), (8, 64, "density_matrix"),
    (10, 255, "statevector"), (10, 256, "density_matrix"), (12, 256, "statevector"),
    (12, 4000, "density_matrix"), (13, 4000, "statevector")])
def test_rule_on_small_cells(active, shots, method):
    assert aer_options(active, shots, True)["method"] == method
