"""The adjoint engine above 2**16 amplitudes (n = 17), on both backends and in a process
started with ``QDENSITY_NUMBA=0``: values against Qiskit ``Statevector`` expectation values,
gradients against central finite differences of those (issue 32, item 1: the numpy path
works on reshaped views there, with no per-gate table of 2**n entries)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from qiskit.circuit import ParameterVector, QuantumCircuit
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.execution import _numba
from qdensity.execution.statevector.adjoint import AdjointEngine

N = 17
#: Central differences with this step: truncation ~ eps**2, rounding ~ 1e-16 / eps.
EPS = 1e-5


def wide_circuit(n: int = N) -> QuantumCircuit:
    """Every kind of operation the compiler emits, on the lowest and the highest qubits."""
    t = ParameterVector("t", 13)
    qc = QuantumCircuit(n)
    qc.h(range(n))
    qc.ry(t[0], n - 1)
    qc.rz(t[1], 0)
    qc.rxx(t[2], 3, n - 1)
    qc.cx(n - 1, 2)
    qc.crx(t[3], n - 1, 5)
    qc.ryy(t[4], 0, n - 2)
    qc.append(RBSGate(t[5]), [n - 3, n - 1])
    qc.append(FBSGate(t[6], 4), [1, 2, 3, 4])
    qc.cp(t[7], 1, n - 1)
    qc.rzx(t[8], n - 1, 7)
    qc.ccx(n - 2, n - 1, 0)
    qc.rzz(t[9], 8, n - 1)
    qc.u(t[10], 0.3, t[11], 12)
    qc.s(n - 1)
    qc.cry(2 * t[12] - 0.4, 0, n - 1)
    qc.y(9)
    return qc


def observables(n: int = N) -> list[SparsePauliOp]:
    return [SparsePauliOp.from_sparse_list([("Z", [n - 1], 1.0)], n),
            SparsePauliOp.from_sparse_list([("XY", [0, n - 1], 0.7), ("ZZ", [2, 9], -0.4),
                                            ("Y", [5], 0.2)], n)]


def values(num_parameters: int) -> np.ndarray:
    return np.random.default_rng(17).uniform(-np.pi, np.pi, (2, num_parameters))


def _expectations(qc, obs, vals) -> np.ndarray:
    out = np.empty((vals.shape[0], len(obs)))
    for r, row in enumerate(vals):
        sv = Statevector(qc.assign_parameters(row))
        out[r] = [sv.expectation_value(o).real for o in obs]
    return out


@pytest.fixture(scope="module")
def oracle():
    """Statevector values and central differences, shapes (R, M) and (R, M, P)."""
    qc, obs = wide_circuit(), observables()
    vals = values(qc.num_parameters)
    fd = np.empty(vals.shape[:1] + (len(obs), qc.num_parameters))
    for p in range(qc.num_parameters):
        step = np.zeros(qc.num_parameters)
        step[p] = EPS
        fd[:, :, p] = (_expectations(qc, obs, vals + step)
                       - _expectations(qc, obs, vals - step)) / (2 * EPS)
    return _expectations(qc, obs, vals), fd


def _check(got_values, got_jac, oracle) -> None:
    want_values, fd = oracle
    np.testing.assert_allclose(got_values, want_values, atol=1e-11)
    # central differences of the exact values: error ~ EPS**2 + 1e-16 / EPS, below 1e-8 here
    np.testing.assert_allclose(got_jac, fd, atol=1e-8)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_above_the_old_cache_size_both_backends_match_statevector(backend, oracle):
    if backend == "numba" and not _numba.available():
        assert os.environ.get("QDENSITY_NUMBA", "1") == "0", "numba is a core dependency"
        pytest.skip("QDENSITY_NUMBA=0 switches the compiled kernels off")
    qc = wide_circuit()
    engine = AdjointEngine(backend=backend)
    vals, jac = engine.value_and_gradient(qc, observables(), values(qc.num_parameters))
    _check(vals, jac, oracle)
    sv = engine.statevector(qc, values(qc.num_parameters)[:1])[0]
    want = Statevector(qc.assign_parameters(values(qc.num_parameters)[0])).data
    # equal up to the global phase the engine drops (u gates, circuit.global_phase)
    phase = np.vdot(sv, want)
    np.testing.assert_allclose(abs(phase), 1.0, atol=1e-11)
    np.testing.assert_allclose(sv * phase, want, atol=1e-11)


def test_a_process_with_qdensity_numba_0_runs_the_numpy_path(oracle):
    """What CI's numpy leg runs: the environment switch, not a monkeypatch."""
    code = (
        "import importlib.util, json, sys\n"
        f"spec = importlib.util.spec_from_file_location('wide', {__file__!r})\n"
        "wide = importlib.util.module_from_spec(spec); spec.loader.exec_module(wide)\n"
        "from qdensity.execution import _numba\n"
        "from qdensity.execution.statevector.adjoint import AdjointEngine\n"
        "qc = wide.wide_circuit()\n"
        "engine = AdjointEngine()\n"
        "v, j = engine.value_and_gradient(qc, wide.observables(), "
        "wide.values(qc.num_parameters))\n"
        "print(json.dumps({'numba': _numba.available(), 'values': v.tolist(), "
        "'jac': j.tolist()}))\n"
    )
    env = dict(os.environ, QDENSITY_NUMBA="0")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          check=True)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["numba"] is False
    _check(np.array(out["values"]), np.array(out["jac"]), oracle)
