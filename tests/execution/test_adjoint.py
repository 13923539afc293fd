"""The adjoint engine against independent oracles: Qiskit statevectors, central finite
differences of those statevectors, and parameter-shift plans run on Aer (issue 16)."""

from __future__ import annotations

import os

import numpy as np
import pytest
from qiskit.circuit import Gate, Parameter, ParameterVector, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate, UnitaryGate
from qiskit.quantum_info import SparsePauliOp, Statevector, random_unitary

from qdensity.circuits.ansatze import (
    angle_encoding,
    equivariant_commuting,
    equivariant_noncommuting,
    hardware_efficient,
    pyramid,
    qcnn,
    reuploading,
)
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.circuits.loaders import unary_loader_template
from qdensity.execution import _numba
from qdensity.execution._threads import num_threads
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import CircuitJob, expectation_plan, measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.statevector import _kernels
from qdensity.execution.statevector.adjoint import AdjointEngine
from qdensity.gradients.shift import parameter_shift_plan

RNG = np.random.default_rng(20261122)


@pytest.fixture(scope="module")
def aer():
    return ExactEngine()


@pytest.fixture(autouse=True, params=["numba", "numpy"])
def backend(request, monkeypatch):
    """Every test runs on the compiled kernels and on the numpy fallback (the path without
    numba, as ``QDENSITY_NUMBA=0`` gives it)."""
    if request.param == "numba" and not _numba.available():
        assert os.environ.get("QDENSITY_NUMBA", "1") == "0", "numba is a core dependency"
        pytest.skip("QDENSITY_NUMBA=0 switches the compiled kernels off")
    if request.param == "numpy":
        monkeypatch.setattr(_numba, "numba", None)
    return request.param


def _every_gate_circuit() -> QuantumCircuit:
    t = ParameterVector("t", 17)
    qc = QuantumCircuit(4)
    qc.h(0)
    qc.ry(t[0], 1)
    qc.rx(2 * t[1] + 0.3, 2)
    qc.cx(0, 3)
    qc.rz(t[2], 0)
    qc.append(RBSGate(t[3]), [0, 1])
    qc.append(FBSGate(t[4], 4), [0, 1, 2, 3])
    qc.append(FBSGate(t[5], 3), [1, 2, 3])
    qc.crx(t[6], 0, 2)
    qc.cry(t[7], 3, 1)
    qc.crz(t[8], 1, 0)
    qc.p(t[9], 2)
    qc.cp(t[10], 1, 3)
    qc.rxx(t[11], 0, 2)
    qc.ryy(t[12], 1, 3)
    qc.rzz(t[13], 0, 1)
    qc.rzx(t[14], 2, 3)
    qc.append(PauliEvolutionGate(SparsePauliOp(["XZY", "ZIZ"], [0.7, -0.4]), time=t[15]),
              [0, 2, 3])
    qc.s(1)
    qc.t(2)
    qc.swap(0, 3)
    qc.cz(0, 1)
    qc.y(2)
    qc.ccx(0, 1, 2)
    qc.rx(0.4, 1)
    qc.append(UnitaryGate(random_unitary(4, seed=3)), [1, 3])
    qc.append(RBSGate(t[0]), [2, 3])  # a shared parameter
    qc.append(RBSGate(1.1), [0, 2])  # a fixed RBS
    qc.u(t[16], 0.2, -0.5, 0)  # a gate reached through its definition
    return qc


def _sv_expectations(qc, observables, values):
    return np.array([[Statevector(qc.assign_parameters(row)).expectation_value(o).real
                      for o in observables] for row in values])


def test_statevectors_match_qiskit_for_every_gate():
    qc = _every_gate_circuit()
    vals = RNG.uniform(-np.pi, np.pi, (3, qc.num_parameters))
    sv = AdjointEngine().statevector(qc, vals)
    for row, got in zip(vals, sv, strict=True):
        ref = Statevector(qc.assign_parameters(row)).data
        phase = np.vdot(got, ref)  # equal up to a global phase (the u gate's is dropped)
        assert abs(abs(phase) - 1) < 1e-12
        np.testing.assert_allclose(got * phase, ref, atol=1e-12)


def test_gradients_match_finite_differences_for_every_gate():
    qc = _every_gate_circuit()
    obs = [SparsePauliOp(["XYZI", "ZZII", "IIIX"], [0.3, 0.5, -1.2]), SparsePauliOp("ZIII")]
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    values, jac = AdjointEngine().value_and_gradient(qc, obs, vals)
    np.testing.assert_allclose(values, _sv_expectations(qc, obs, vals), atol=1e-12)
    eps = 1e-6
    fd = np.zeros_like(jac)
    for p in range(qc.num_parameters):
        step = np.zeros(qc.num_parameters)
        step[p] = eps
        fd[:, :, p] = (_sv_expectations(qc, obs, vals + step)
                       - _sv_expectations(qc, obs, vals - step)) / (2 * eps)
    np.testing.assert_allclose(jac, fd, atol=1e-7)


def test_wrt_selects_columns_and_diagonal_observables_read_probabilities():
    qc = _every_gate_circuit()
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    eng = AdjointEngine()
    indicator = np.zeros(16)
    indicator[5] = 1.0
    values, jac = eng.value_and_gradient(qc, [indicator, "IIZZ"], vals)
    _, part = eng.value_and_gradient(qc, [indicator, "IIZZ"], vals, wrt=[16, 4])
    np.testing.assert_allclose(part, jac[:, :, [16, 4]], atol=1e-14)
    probs = np.array([Statevector(qc.assign_parameters(r)).probabilities() for r in vals])
    np.testing.assert_allclose(values[:, 0], probs[:, 5], atol=1e-12)
    np.testing.assert_allclose(eng.probabilities(qc, vals), probs, atol=1e-12)


def _family_cases():
    n = 4
    loader = unary_loader_template(n, parameter_prefix="φ")
    yield "pyramid+loader", loader.compose(pyramid(n)), SparsePauliOp("IIZI")
    yield "hardware_efficient", hardware_efficient(n, 2, ("ry", "rz")), SparsePauliOp("XIZZ")
    enc = angle_encoding(n)
    z = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    yield "equivariant_xx", enc.compose(equivariant_commuting(n, "X", 2)), z
    yield "equivariant_yy", enc.compose(equivariant_commuting(n, "Y", 2)), z
    yield "equivariant_noncommuting", enc.compose(equivariant_noncommuting(n, 2)), z
    yield "qcnn", enc.compose(qcnn(n)), SparsePauliOp("ZIII")
    yield "reuploading", reuploading(4), SparsePauliOp("Z")


@pytest.mark.parametrize("name, circuit, observable", list(_family_cases()),
                         ids=[c[0] for c in _family_cases()])
def test_every_family_matches_parameter_shift_on_aer(name, circuit, observable, aer):
    vals = RNG.uniform(-np.pi, np.pi, (2, circuit.num_parameters))
    values, jac = AdjointEngine().value_and_gradient(circuit, observable, vals)
    shift = parameter_shift_plan(circuit, observable, vals).run(aer).value
    np.testing.assert_allclose(jac[:, 0, :], shift, atol=1e-9)
    exact = expectation_plan(circuit, observable, vals).run(aer).value
    np.testing.assert_allclose(values[:, 0], exact, atol=1e-9)


def test_plans_run_on_the_adjoint_engine_like_aer(aer):
    qc = hardware_efficient(3, 2)
    meas = QuantumCircuit(3, 2)
    meas.compose(qc, inplace=True)
    meas.measure(2, 0)  # clbit 0 <- qubit 2, clbit 1 <- qubit 0: a permuted marginal
    meas.measure(0, 1)
    vals = RNG.uniform(-np.pi, np.pi, (3, qc.num_parameters))
    jobs = [CircuitJob(meas, vals), CircuitJob(measured(qc), vals)]
    for ours, ref in zip(AdjointEngine().run(jobs), aer.run(jobs), strict=True):
        np.testing.assert_allclose(ours.probabilities, ref.probabilities, atol=1e-12)


def test_compiles_each_circuit_once():
    eng = AdjointEngine()
    qc = qcnn(4)
    vals = np.zeros((1, qc.num_parameters))
    for _ in range(3):
        eng.value_and_gradient(qc, "ZIII", vals)
    eng.expectation(qcnn(4), "ZIII", vals)  # rebuilt, same structure
    assert eng.compile_count == 1


def test_a_circuit_or_observable_changed_in_place_is_not_read_stale():
    """The engine recognises a circuit and the last observables by identity; one changed in
    place after a run must give the changed answer (Qiskit statevectors as the oracle)."""
    eng = AdjointEngine()
    t = Parameter("t")
    qc = QuantumCircuit(2)
    qc.ry(t, 0)
    obs = SparsePauliOp(["IZ", "ZI"], [1.0, 1.0])

    def want(circuit, op, value):
        return Statevector(circuit.assign_parameters([value])).expectation_value(op).real

    assert eng.expectation(qc, obs, [[0.3]])[0, 0] == pytest.approx(want(qc, obs, 0.3))
    qc.x(1)  # appended
    assert eng.expectation(qc, obs, [[0.3]])[0, 0] == pytest.approx(want(qc, obs, 0.3))
    obs.coeffs[1] = 2.5  # a coefficient changed in place
    assert eng.expectation(qc, obs, [[0.3]])[0, 0] == pytest.approx(want(qc, obs, 0.3))
    obs.paulis.z[0] = [False, True]  # IZ -> ZI in place
    value, grad = eng.value_and_gradient(qc, obs, [[0.3]])
    assert value[0, 0] == pytest.approx(want(qc, obs, 0.3))
    fd = (want(qc, obs, 0.3 + 1e-6) - want(qc, obs, 0.3 - 1e-6)) / 2e-6
    assert grad[0, 0, 0] == pytest.approx(fd, abs=1e-6)
    qc.data.pop()  # removed again, and a measured copy through run()
    assert eng.expectation(qc, obs, [[0.3]])[0, 0] == pytest.approx(want(qc, obs, 0.3))
    meas = measured(qc)
    p1 = eng.run([CircuitJob(meas, [[0.3]])])[0].probabilities
    meas.x(1)
    meas.data.insert(len(meas.data) - 2, meas.data.pop())  # the X before the measurements
    p2 = eng.run([CircuitJob(meas, [[0.3]])])[0].probabilities
    np.testing.assert_allclose(p2.reshape(-1), np.abs(Statevector(
        meas.remove_final_measurements(inplace=False).assign_parameters([0.3])).data) ** 2,
        atol=1e-12)
    assert not np.allclose(p1, p2)


def test_rows_are_chunked_under_the_memory_budget():
    qc = hardware_efficient(3, 2)
    vals = RNG.uniform(-np.pi, np.pi, (7, qc.num_parameters))
    big = AdjointEngine().value_and_gradient(qc, "ZZI", vals)
    small = AdjointEngine(memory_budget=16 * 8 * 3).value_and_gradient(qc, "ZZI", vals)
    for a, b in zip(big, small, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-14)


def test_chunk_sizes_follow_both_budgets():
    # per row 16 * 2**3 * 3 = 384 bytes: the cache budget gives 2 rows, raised to min_rows,
    # never above what memory_budget allows (5 rows)
    eng = AdjointEngine(memory_budget=384 * 5)
    sizes = lambda **kw: [s.stop - s.start for s in eng._chunks(12, 3, 3, **kw)]  # noqa: E731
    assert sizes() == [5, 5, 2]
    assert sizes(budget=384 * 2) == [2] * 6
    assert sizes(budget=384 * 2, min_rows=3) == [3] * 4
    assert sizes(budget=384 * 2, min_rows=8) == [5, 5, 2]
    assert sizes(budget=100) == [5, 5, 2]  # not one row fits the cache: memory_budget's chunks


def test_compiled_rows_in_cache_sized_chunks_give_the_one_chunk_result(monkeypatch):
    # the compiled kernels run cache-sized chunks of at least numba's threads; the numpy
    # path keeps the memory budget's one chunk (and never calls the kernels)
    from qdensity.execution.statevector import adjoint as adjoint_module

    qc = hardware_efficient(3, 2)
    vals = RNG.uniform(-np.pi, np.pi, (9, qc.num_parameters))
    whole = AdjointEngine().value_and_gradient(qc, ["ZZI", "XIY"], vals)
    seen = []
    forward = _kernels.forward
    # rows: axis -2 of a complex (R, 2**n) or planar (2, R, 2**n) state
    monkeypatch.setattr(_kernels, "forward", lambda phi, *a: (seen.append(phi.shape[-2]),
                                                               forward(phi, *a)))
    monkeypatch.setattr(adjoint_module, "CACHE_BUDGET", 16 * 8 * 4 * 2)  # 2 rows of 4 copies
    chunked = AdjointEngine().value_and_gradient(qc, ["ZZI", "XIY"], vals)
    if _numba.available():
        size = max(2, num_threads())
        assert seen == [size] * (9 // size) + ([9 % size] if 9 % size else [])
    else:
        assert seen == []
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-14)


def test_refuses_wide_circuits_before_allocating():
    wide = QuantumCircuit(40)
    wide.ry(Parameter("t"), 0)
    with pytest.raises(ValueError, match=r"max_qubits = 20.*unary engine.*SamplerEngine"):
        AdjointEngine().value_and_gradient(wide, SparsePauliOp("Z" * 40), [[0.1]])
    with pytest.raises(ValueError, match=r"max_qubits = 3"):
        AdjointEngine(max_qubits=3).statevector(hardware_efficient(4, 1), np.zeros(4))
    with pytest.raises(ValueError, match="max_qubits must be an int >= 1 and <= 30"):
        AdjointEngine(max_qubits=31)


def test_bad_gates_and_inputs_are_named():
    class Opaque(Gate):
        def __init__(self, theta):
            super().__init__("opaque", 1, [theta])

    qc = QuantumCircuit(1)
    qc.append(Opaque(Parameter("t")), [0])
    with pytest.raises(ValueError, match=r"'opaque'.*supported: rx, ry, rz"):
        AdjointEngine().statevector(qc, [0.1])
    t = Parameter("t")
    nonlinear = QuantumCircuit(1)
    nonlinear.ry(t * t, 0)
    with pytest.raises(ValueError, match="not linear"):
        AdjointEngine().statevector(nonlinear, [0.1])
    noncommuting = QuantumCircuit(2)
    noncommuting.append(PauliEvolutionGate(SparsePauliOp(["XX", "ZI"]), time=t), [0, 1])
    with pytest.raises(ValueError, match="non-commuting"):
        AdjointEngine().statevector(noncommuting, [0.1])
    ok = hardware_efficient(2, 1)
    with pytest.raises(ValueError, match=r"\(rows, 2\)"):
        AdjointEngine().expectation(ok, "ZZ", np.zeros((2, 3)))
    with pytest.raises(ValueError, match="wrt"):
        AdjointEngine().value_and_gradient(ok, "ZZ", np.zeros(2), wrt=[5])
    with pytest.raises(ValueError, match="length 2\\*\\*n = 4"):
        AdjointEngine().expectation(ok, np.ones(3), np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        AdjointEngine().expectation(ok, "ZZ", [np.nan, 0.0])


def test_structurally_equal_templates_differ_by_pauli_operator(aer):
    """XX and YY evolutions share a gate name and angle; neither engine may confuse them."""
    n = 3
    z = SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
    enc = angle_encoding(n)
    eng = AdjointEngine()
    vals = RNG.uniform(-1, 1, (2, n + 2))
    for pauli in ("X", "Y"):
        qc = enc.compose(equivariant_commuting(n, pauli, 2))
        ref = _sv_expectations(qc, [z], vals)[:, 0]
        np.testing.assert_allclose(eng.expectation(qc, z, vals)[:, 0], ref, atol=1e-12)
        np.testing.assert_allclose(expectation_plan(qc, z, vals).run(aer).value, ref, atol=1e-9)
    assert eng.compile_count == 2


def test_aer_engines_bind_controlled_rotations_correctly(aer):
    """qiskit-aer 0.18 binds parameterised crx/cry/crz/cp wrongly from parameter arrays; the
    engines unroll them, so QCNN values on Aer equal exact statevectors."""
    qc = QuantumCircuit(2)
    t = ParameterVector("t", 4)
    qc.h(0)
    qc.ry(0.4, 1)
    qc.crx(t[0], 0, 1)
    qc.cry(t[1], 1, 0)
    qc.crz(t[2], 0, 1)
    qc.cp(t[3], 1, 0)
    qc.h([0, 1])
    vals = RNG.uniform(-np.pi, np.pi, (3, 4))
    ref = np.array([Statevector(qc.assign_parameters(v)).probabilities() for v in vals])
    res = aer.run([CircuitJob(measured(qc), vals)])[0]
    np.testing.assert_allclose(res.probabilities, ref, atol=1e-12)
    sampled = SamplerEngine(seed=5).run([CircuitJob(measured(qc), vals, 4000)])[0]
    assert np.all(np.abs(sampled.probabilities - ref) < 5 * np.sqrt(0.25 / 4000) + 1e-12)


def test_the_compiled_path_runs_every_gate_and_parallel_rows_agree(backend, monkeypatch):
    """The numba parametrisation really runs the kernels (every gate of the circuit has a
    kernel rule), and rows split over threads (forced: tests are below the work threshold)
    give the finite-difference gradients too, and the same bits as one thread."""
    qc = _every_gate_circuit()
    prog = AdjointEngine().compile(qc)
    assert (_kernels.tables(prog) is not None) == (backend == "numba")
    obs = [SparsePauliOp("ZXIY"), SparsePauliOp(["IZZI", "XIIX"], [0.4, 0.9])]
    vals = RNG.uniform(-np.pi, np.pi, (5, qc.num_parameters))
    if backend == "numba":
        one = AdjointEngine().value_and_gradient(qc, obs, vals)  # below the threshold
        monkeypatch.setattr(_kernels, "PARALLEL_WORK", 0)
        monkeypatch.setattr(_kernels, "LOAD_AWARE", False)
        monkeypatch.setenv("QDENSITY_NUM_THREADS", "3")
        calls = []
        for name in ("forward_rows", "backward_rows"):
            kernel = getattr(_kernels._planar, name)
            monkeypatch.setattr(_kernels._planar, name, lambda *a, k=kernel, name=name: (
                calls.append((name, a[0].shape[0])), k(*a)))
    values, jac = AdjointEngine().value_and_gradient(qc, obs, vals)
    if backend == "numba":  # 5 rows in blocks of 1, 2, 2 for 3 threads (the pool's)
        for name in ("forward_rows", "backward_rows"):
            assert sorted(c[1] for c in calls if c[0] == name) == [1, 2, 2]
        assert np.array_equal(values, one[0]) and np.array_equal(jac, one[1])
    np.testing.assert_allclose(values, _sv_expectations(qc, obs, vals), atol=1e-12)
    eps = 1e-6
    for p in (0, 4, 9, 15):
        step = np.zeros(qc.num_parameters)
        step[p] = eps
        fd = (_sv_expectations(qc, obs, vals + step)
              - _sv_expectations(qc, obs, vals - step)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, p], fd, atol=1e-7)


def test_qdensity_numba_0_selects_the_numpy_path():
    import os
    import subprocess
    import sys

    env = dict(os.environ, QDENSITY_NUMBA="0")
    code = ("from qdensity.execution import _numba; "
            "from qdensity.execution.statevector.adjoint import AdjointEngine; "
            "print(_numba.available(), AdjointEngine().backend)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == ["False", "auto"]
    with pytest.raises(ValueError, match="backend"):
        AdjointEngine(backend="gpu")


def _wide_circuit(n: int) -> QuantumCircuit:
    """Every Pauli kind on low and high qubits of an ``n``-qubit register (blocks of 1 to
    2**(n - 1) contiguous amplitudes in the kernels), one parameter per rotation."""
    t = ParameterVector("t", 7 * n)
    qc = QuantumCircuit(n)
    qc.h(range(n))
    g = 0
    for q in range(n):
        r = (q + 3) % n
        qc.ry(t[g], q)
        qc.rz(t[g + 1], q)
        qc.rx(t[g + 2], r)
        qc.rzz(t[g + 3], q, r)
        qc.rxx(t[g + 4], r, q)
        qc.ryy(t[g + 5], q, (q + 1) % n)
        qc.rzx(t[g + 6], q, r)
        qc.cx(q, (q + 1) % n)
        qc.cz(r, q)
        g += 7
    qc.ccx(n - 1, 0, n // 2)
    qc.s(n - 2)
    return qc


@pytest.mark.parametrize("n", [7, 9])
def test_wide_circuits_match_statevectors_and_parameter_shift(n):
    """At widths where the kernels' vectorised blocks (8 amplitudes and more) and their
    one-pair-at-a-time short blocks both run: values against Qiskit statevectors, gradients
    against the exact two-term shift rule of each single-Pauli rotation, for one observable
    and for two."""
    qc = _wide_circuit(n)
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    for obs in ([SparsePauliOp("Z" + "I" * (n - 1))],
                [SparsePauliOp("X" + "I" * (n - 2) + "Y"),
                 SparsePauliOp(["I" * (n - 3) + "ZZI", "Y" + "I" * (n - 1)], [0.4, 0.9])]):
        values, jac = AdjointEngine().value_and_gradient(qc, obs, vals)
        np.testing.assert_allclose(values, _sv_expectations(qc, obs, vals), atol=1e-12)
        for p in range(0, qc.num_parameters, 3 if n > 7 else 1):
            step = np.zeros(qc.num_parameters)
            step[p] = np.pi / 2
            shift = (_sv_expectations(qc, obs, vals + step)
                     - _sv_expectations(qc, obs, vals - step)) / 2
            np.testing.assert_allclose(jac[:, :, p], shift, atol=1e-10)


def _moving_layout(monkeypatch, low: int) -> None:
    """Run the kernels in the moving layout of statevector._layout at test widths, on
    parallel rows (both are off below 10 qubits and under the work threshold)."""
    from qdensity.execution.statevector import _layout

    monkeypatch.setattr(_layout, "MIN_QUBITS", 0)
    monkeypatch.setattr(_layout, "LOW_BITS", low)
    monkeypatch.setattr(_kernels, "PARALLEL_WORK", 0)
    monkeypatch.setattr(_kernels, "LOAD_AWARE", False)


@pytest.mark.parametrize("n, low", [(8, 2), (9, 3)])
def test_moving_layout_matches_statevectors_and_parameter_shift(backend, monkeypatch, n, low):
    """Gates on the low qubits run after a permutation parks other qubits there (numba path;
    the numpy path runs the same circuit in the identity layout): values against Qiskit
    statevectors, gradients against the exact shift rule, statevectors in qubit order."""
    _moving_layout(monkeypatch, low)
    qc = _wide_circuit(n)
    eng = AdjointEngine()
    if backend == "numba":
        tab = _kernels.tables(eng.compile(qc))
        assert np.count_nonzero(tab.kind == 3) >= 4  # the layout really moves
    vals = RNG.uniform(-np.pi, np.pi, (3, qc.num_parameters))
    obs = [SparsePauliOp("X" + "I" * (n - 2) + "Y"),
           SparsePauliOp(["I" * (n - 3) + "ZZI", "Z" + "I" * (n - 1)], [0.4, 0.9])]
    values, jac = eng.value_and_gradient(qc, obs, vals)
    np.testing.assert_allclose(values, _sv_expectations(qc, obs, vals), atol=1e-12)
    for p in range(0, qc.num_parameters, 4):
        step = np.zeros(qc.num_parameters)
        step[p] = np.pi / 2
        shift = (_sv_expectations(qc, obs, vals + step)
                 - _sv_expectations(qc, obs, vals - step)) / 2
        np.testing.assert_allclose(jac[:, :, p], shift, atol=1e-10)
    ref = Statevector(qc.assign_parameters(vals[0])).data
    np.testing.assert_allclose(eng.statevector(qc, vals[:1])[0], ref, atol=1e-12)


def test_moving_layout_runs_every_gate_kind(backend, monkeypatch):
    """Every gate of the every-gate circuit (dense fixed gates, controls, phases, FBS parity
    strings) on low qubits of a wider register, in a moving layout: values and central
    finite-difference gradients of Qiskit statevectors."""
    _moving_layout(monkeypatch, 2)
    sub = _every_gate_circuit()
    qc = QuantumCircuit(9)
    qc.h(range(9))
    qc.cx(8, 0)
    qc.compose(sub, qubits=[0, 1, 2, 3], inplace=True)
    qc.cz(1, 7)
    qc.compose(sub, qubits=[6, 0, 8, 2], inplace=True)  # the same parameters again
    if backend == "numba":
        assert np.count_nonzero(_kernels.tables(AdjointEngine().compile(qc)).kind == 3) >= 2
    obs = [SparsePauliOp("ZIIIIIXIY"), SparsePauliOp("IIIIIIIZZ")]
    vals = RNG.uniform(-np.pi, np.pi, (2, qc.num_parameters))
    values, jac = AdjointEngine().value_and_gradient(qc, obs, vals)
    np.testing.assert_allclose(values, _sv_expectations(qc, obs, vals), atol=1e-12)
    eps = 1e-6
    for p in range(qc.num_parameters):
        step = np.zeros(qc.num_parameters)
        step[p] = eps
        fd = (_sv_expectations(qc, obs, vals + step)
              - _sv_expectations(qc, obs, vals - step)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, p], fd, atol=1e-7)
