"""The torch engines on CPU torch: the unary engine on tensors and ``AdjointEngine(backend=
"torch")`` against qiskit statevectors, finite differences and the numpy engines (1e-10 in
float64), tensors kept on their device and dtype, bad input refused before any work."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the optional extra; CI installs it (.ci/run)

from qiskit import QuantumCircuit  # noqa: E402
from qiskit.circuit import ParameterVector  # noqa: E402
from qiskit.circuit.library import PauliEvolutionGate  # noqa: E402
from qiskit.quantum_info import SparsePauliOp, Statevector  # noqa: E402

from qdensity.circuits.ansatze import (  # noqa: E402
    butterfly,
    hardware_efficient,
    pyramid,
    qcnn,
    round_robin,
)
from qdensity.circuits.gates import FBSGate, RBSGate  # noqa: E402
from qdensity.execution import _torch as device_helpers  # noqa: E402
from qdensity.execution.statevector.adjoint import AdjointEngine  # noqa: E402
from qdensity.execution.unary import (  # noqa: E402
    UnaryCircuit,
    compile_unary,
    forward,
    jacobian,
    vjp,
)

TOL = 1e-10


def _t(a, dtype=torch.float64):
    return torch.tensor(np.asarray(a), dtype=dtype)


def _unary_circuits():
    qc = QuantumCircuit(4)  # shared parameters, affine angles, a fixed angle, an FBS gate
    p = ParameterVector("p", 2)
    qc.append(RBSGate(2 * p[0] + 0.3), [0, 1])
    qc.append(FBSGate(p[1], 3), [1, 2, 3])
    qc.append(RBSGate(0.4), [2, 3])
    qc.append(RBSGate(-p[0]), [3, 0])
    return [pyramid(5), butterfly(4), round_robin(6), qc]


# ---------------------------------------------------------------------------- unary engine
@pytest.mark.parametrize("circuit", _unary_circuits(), ids=lambda c: c.name)
def test_unary_forward_equals_statevector_simulation(circuit):
    """Oracle: qiskit's Statevector of the circuit on the dense unary input, read at 2**j."""
    rng = np.random.default_rng(0)
    n, P = circuit.num_qubits, circuit.num_parameters
    X, V = rng.normal(size=(3, n)), rng.normal(size=(3, P))
    Y = forward(circuit, _t(X), _t(V))
    for b in range(3):
        psi = np.zeros(2**n, dtype=complex)
        psi[[2**j for j in range(n)]] = X[b]
        out = Statevector(psi).evolve(circuit.assign_parameters(V[b])).data
        np.testing.assert_allclose(Y[b].numpy(), out[[2**j for j in range(n)]].real, atol=TOL)


@pytest.mark.parametrize("circuit", _unary_circuits(), ids=lambda c: c.name)
@pytest.mark.parametrize("rows", ["shared", "per_row"])
@pytest.mark.parametrize("batch", [1, 3, 40])  # 40 > n: the shared path builds O first
def test_unary_torch_equals_numpy_engine(circuit, rows, batch):
    rng = np.random.default_rng(1)
    c = compile_unary(circuit)
    n, P = c.num_qubits, c.num_parameters
    X, gY = rng.normal(size=(batch, n)), rng.normal(size=(batch, n))
    V = rng.normal(size=P) if rows == "shared" else rng.normal(size=(batch, P))
    Y = forward(c, _t(X), _t(V))
    assert isinstance(Y, torch.Tensor) and Y.dtype == torch.float64
    np.testing.assert_allclose(Y.numpy(), forward(c, X, V), atol=TOL)
    for reduce in ("none", "sum"):
        gv, gx = vjp(c, _t(X), _t(V), _t(gY), reduce=reduce)
        gv0, gx0 = vjp(c, X, V, gY, reduce=reduce)
        assert gv.shape == gv0.shape and gx.shape == gx0.shape
        np.testing.assert_allclose(gv.numpy(), gv0, atol=TOL)
        np.testing.assert_allclose(gx.numpy(), gx0, atol=TOL)
    # starting from the caller's outputs gives the same gradient
    gv1, _ = vjp(c, _t(X), V, _t(gY), reduce="sum", outputs=Y)
    np.testing.assert_allclose(gv1.numpy(), vjp(c, X, V, gY, reduce="sum")[0], atol=TOL)


def test_unary_single_input_and_jacobian_against_finite_differences():
    rng = np.random.default_rng(2)
    c = compile_unary(_unary_circuits()[3])
    x, v = rng.normal(size=4), rng.normal(size=c.num_parameters)
    y = forward(c, _t(x), _t(v))
    assert y.shape == (4,)
    J = jacobian(c, _t(x), _t(v))
    assert J.shape == (4, c.num_parameters)
    h = 1e-6
    for p in range(c.num_parameters):
        e = np.zeros_like(v)
        e[p] = h
        fd = (forward(c, x, v + e) - forward(c, x, v - e)) / (2 * h)
        np.testing.assert_allclose(J[:, p].numpy(), fd, atol=1e-8)
    np.testing.assert_allclose(J.numpy(), jacobian(c, x, v), atol=TOL)
    gv, gx = vjp(c, _t(x), _t(v), _t(np.eye(4)[1]))
    np.testing.assert_allclose(gv.numpy(), J[1].numpy(), atol=TOL)
    assert gx.shape == (4,)


def test_unary_float32_stays_float32_and_close_to_float64():
    rng = np.random.default_rng(3)
    c = UnaryCircuit.from_gates(6, [(0, 1), (2, 3), (1, 2), (4, 5), (3, 4), (0, 5)])
    X, V, gY = rng.normal(size=(5, 6)), rng.normal(size=6), rng.normal(size=(5, 6))
    y = forward(c, _t(X, torch.float32), V)  # numpy values follow the tensor's dtype
    gv, gx = vjp(c, _t(X, torch.float32), _t(V, torch.float32), _t(gY, torch.float32),
                 reduce="sum")
    assert y.dtype == gv.dtype == gx.dtype == torch.float32
    np.testing.assert_allclose(y.numpy(), forward(c, X, V), atol=1e-5)
    np.testing.assert_allclose(gv.numpy(), vjp(c, X, V, gY, reduce="sum")[0], atol=1e-4)


def test_unary_results_stay_on_the_input_device():
    """A ``meta`` tensor carries a device but no data: the engine runs its layers there and
    returns meta tensors of the right shapes (nothing is copied to the host)."""
    c = compile_unary(pyramid(5))
    X = torch.empty(7, 5, device="meta", dtype=torch.float32)
    V = torch.empty(7, c.num_parameters, device="meta", dtype=torch.float32)
    Y = forward(c, X, V)
    assert Y.device.type == "meta" and Y.shape == (7, 5) and Y.dtype == torch.float32
    gv, gx = vjp(c, X, V, torch.empty(7, 5, device="meta"))
    assert gv.device.type == gx.device.type == "meta"
    assert gv.shape == (7, c.num_parameters) and gx.shape == (7, 5)


def test_unary_numpy_input_keeps_the_numpy_path():
    c = compile_unary(pyramid(4))
    y = forward(c, np.eye(4)[0], np.zeros(6))
    assert isinstance(y, np.ndarray)


@pytest.mark.parametrize(("X", "V", "error", "match"), [
    (torch.zeros(2, 4, dtype=torch.complex128), np.zeros(6), TypeError, "real"),
    (torch.zeros(2, 4, dtype=torch.int64), np.zeros(6), TypeError, "float32 or float64"),
    (torch.zeros(2, 4, dtype=torch.float16), np.zeros(6), TypeError, "float32 or float64"),
    (torch.zeros(2, 5, dtype=torch.float64), np.zeros(6), ValueError, r"\(batch, 4\)"),
    (torch.zeros(2, 4, dtype=torch.float64), np.zeros(5), ValueError, r"\(6,\)"),
    (torch.zeros(2, 4, dtype=torch.float64), np.zeros((3, 6)), ValueError, "3 rows"),
    (torch.full((2, 4), float("nan"), dtype=torch.float64), np.zeros(6), ValueError, "finite"),
    (torch.zeros(2, 4, dtype=torch.float64), [float("inf")] * 6, ValueError, "finite"),
])
def test_unary_torch_bad_input(X, V, error, match):
    with pytest.raises(error, match=match):
        forward(pyramid(4), X, V)


def test_unary_vjp_bad_grad_shape():
    with pytest.raises(ValueError, match="grad_Y must have the output's shape"):
        vjp(pyramid(4), torch.zeros(2, 4, dtype=torch.float64), np.zeros(6),
            torch.zeros(3, 4, dtype=torch.float64))


# ---------------------------------------------------------------------------- adjoint engine
def _mixed_circuit():
    """Every op kind of the compiled program: fixed Paulis and matrices, controlled
    rotations, phases, u gates, diagonal rotations, a parameter in several gates, an affine
    angle."""
    p = ParameterVector("p", 6)
    qc = QuantumCircuit(4)
    qc.h(0)
    qc.cx(0, 1)
    qc.crx(p[0], 1, 2)
    qc.cp(p[1], 2, 3)
    qc.u(p[2], p[3], 0.3, 1)
    qc.ccx(0, 1, 3)
    qc.rzx(2 * p[4] + 0.1, 0, 3)
    qc.p(p[5], 0)
    qc.swap(1, 2)
    qc.cry(p[0], 3, 0)
    qc.append(RBSGate(p[2]), [1, 3])
    # diagonal rotations: one Z, controlled, two Z's, and four (past the sliced ones)
    qc.rz(p[3], 2)
    qc.crz(p[4], 0, 2)
    qc.rzz(p[5], 1, 3)
    qc.append(PauliEvolutionGate(SparsePauliOp("ZZZZ"), time=p[1]), range(4))
    qc.ry(p[0], 3)
    return qc


_OBS = [SparsePauliOp.from_list([("ZIIX", 0.5), ("IYZI", -0.3), ("ZZII", 0.7)]), "IIIZ"]


@pytest.mark.parametrize("circuit", [_mixed_circuit(), hardware_efficient(4, 2), qcnn(4),
                                     round_robin(4)], ids=lambda c: c.name)
def test_adjoint_torch_equals_numpy_engine_and_statevectors(circuit):
    rng = np.random.default_rng(4)
    P = circuit.num_parameters
    vals = rng.uniform(-3, 3, size=(3, P))
    diag = rng.normal(size=16)
    obs = [*_OBS, diag]
    ref, eng = AdjointEngine(backend="numpy"), AdjointEngine(backend="torch")
    v0, j0 = ref.value_and_gradient(circuit, obs, vals)
    v1, j1 = eng.value_and_gradient(circuit, obs, vals)
    assert isinstance(v1, np.ndarray)
    np.testing.assert_allclose(v1, v0, atol=TOL)
    np.testing.assert_allclose(j1, j0, atol=TOL)
    wrt = [0, P - 1]
    np.testing.assert_allclose(eng.value_and_gradient(circuit, obs, vals, wrt)[1],
                               ref.value_and_gradient(circuit, obs, vals, wrt)[1], atol=TOL)
    np.testing.assert_allclose(eng.expectation(circuit, obs, vals), v0, atol=TOL)
    # oracle: qiskit statevectors (up to a global phase) and their expectation values
    psi = eng.statevector(circuit, vals)
    for r in range(3):
        exact = Statevector(circuit.assign_parameters(vals[r]))
        overlap = np.vdot(exact.data, psi[r])
        assert abs(abs(overlap) - 1) < TOL
        np.testing.assert_allclose(v1[r, 0], exact.expectation_value(_OBS[0]).real, atol=TOL)
        np.testing.assert_allclose(v1[r, 2], np.abs(exact.data) ** 2 @ diag, atol=TOL)


def test_adjoint_torch_gradient_against_finite_differences_of_statevectors():
    qc = _mixed_circuit()
    rng = np.random.default_rng(5)
    v = rng.uniform(-3, 3, size=qc.num_parameters)
    _, jac = AdjointEngine(backend="torch").value_and_gradient(qc, _OBS[0], v)

    def f(x):
        return Statevector(qc.assign_parameters(x)).expectation_value(_OBS[0]).real

    h = 1e-6
    for p in range(qc.num_parameters):
        e = np.zeros_like(v)
        e[p] = h
        assert abs(jac[0, 0, p] - (f(v + e) - f(v - e)) / (2 * h)) < 1e-7


def test_adjoint_tensor_values_give_tensors_and_complex64_is_float32():
    qc = hardware_efficient(3, 1)
    vals = np.random.default_rng(6).uniform(-3, 3, size=(2, qc.num_parameters))
    eng = AdjointEngine(backend="torch")
    v, j = eng.value_and_gradient(qc, "ZII", torch.tensor(vals))
    assert isinstance(v, torch.Tensor) and v.dtype == j.dtype == torch.float64
    psi = eng.statevector(qc, torch.tensor(vals))
    assert psi.dtype == torch.complex128
    probs = eng.probabilities(qc, torch.tensor(vals))
    np.testing.assert_allclose(probs.sum(dim=1).numpy(), 1.0, atol=TOL)
    e32 = AdjointEngine(backend="torch", dtype="complex64")
    v32, j32 = e32.value_and_gradient(qc, "ZII", torch.tensor(vals))
    assert v32.dtype == j32.dtype == torch.float32
    ref = AdjointEngine(backend="numpy").value_and_gradient(qc, "ZII", vals)
    np.testing.assert_allclose(j32.numpy(), ref[1], atol=1e-5)


def test_adjoint_torch_sees_an_observable_changed_in_place():
    qc = hardware_efficient(3, 1)
    vals = np.random.default_rng(8).uniform(-3, 3, size=(2, qc.num_parameters))
    eng = AdjointEngine(backend="torch")
    op, diag = SparsePauliOp.from_list([("ZII", 1.0)]), np.ones(8)
    eng.value_and_gradient(qc, [op, diag], vals)
    op.coeffs[0] = -2.0
    diag[:] = np.arange(8.0)
    got = eng.value_and_gradient(qc, [op, diag], vals)[0]
    for r in range(2):
        exact = Statevector(qc.assign_parameters(vals[r]))
        assert abs(got[r, 0] + 2 * exact.expectation_value(SparsePauliOp("ZII")).real) < TOL
        assert abs(got[r, 1] - exact.probabilities() @ np.arange(8.0)) < TOL


def test_adjoint_torch_runs_plans_like_the_numpy_engine():
    from qdensity.execution.plans import probabilities_plan

    qc = hardware_efficient(3, 1)
    vals = np.random.default_rng(7).uniform(-3, 3, size=(2, qc.num_parameters))
    jobs = probabilities_plan(qc, vals).jobs
    got = AdjointEngine(backend="torch").run(jobs)[0].probabilities
    for r in range(2):  # oracle: qiskit's probabilities of the bound circuit
        exact = Statevector(qc.assign_parameters(vals[r])).probabilities()
        np.testing.assert_allclose(got[r], exact, atol=TOL)


# ---------------------------------------------------------------------------- bad input
def test_cuda_device_refused_where_no_gpu_is_visible(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ValueError, match=r"device='cuda'.*is_available\(\) is False, 0 CUDA"):
        AdjointEngine(backend="torch", device="cuda")


def test_cuda_ordinal_past_the_count_refused(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    with pytest.raises(ValueError, match=r"'cuda:1' is not available.*1 CUDA device"):
        AdjointEngine(backend="torch", device="cuda:1")


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"backend": "torch", "device": "warp-drive"}, ValueError, "warp-drive"),
    ({"backend": "torch", "device": 2.5}, TypeError, "device must be"),
    ({"backend": "torch", "dtype": "float32"}, ValueError, "complex128"),
    ({"backend": "numpy", "device": "cpu"}, ValueError, "backend='torch' only"),
])
def test_adjoint_torch_bad_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        AdjointEngine(**kwargs)


def test_a_state_that_does_not_fit_is_refused_before_allocation(monkeypatch):
    """One row of a 12-qubit sweep with two observables plans for 3 M + 3 = 9 states of
    2**12 complex128 amplitudes: 9 * 4096 * 16 = 589824 bytes; with 100 kB free it is refused,
    and no state tensor is created (torch.zeros / torch.empty would be the first)."""
    monkeypatch.setattr(device_helpers, "free_bytes", lambda device: 100_000)
    qc = hardware_efficient(12, 1)
    eng = AdjointEngine(backend="torch")
    made = []
    for name in ("zeros", "empty"):
        real = getattr(torch, name)
        monkeypatch.setattr(torch, name, lambda *a, _r=real, **k: made.append(a) or _r(*a, **k))
    with pytest.raises(ValueError, match=r"needs 589824 bytes .* 100000 bytes"):
        eng.value_and_gradient(qc, ["Z" + "I" * 11, "I" * 11 + "Z"],
                               np.zeros((1, qc.num_parameters)))
    assert not any(a and isinstance(a[0], tuple) and 4096 in a[0] for a in made)


def test_gpu_free_memory_is_read_from_mem_get_info(monkeypatch):
    monkeypatch.setattr(torch.cuda, "mem_get_info", lambda device=None: (10**9, 8 * 10**10))
    with pytest.raises(ValueError, match=r"needs 2000000000 bytes .* cuda.*1000000000 bytes"):
        device_helpers.check_fits(torch.device("cuda"), 2 * 10**9, "a state")
    device_helpers.check_fits(torch.device("cuda"), 10**8, "a state")  # fits


def test_cpu_bound_is_the_available_host_memory():
    import os

    total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < device_helpers.free_bytes(torch.device("cpu")) <= total
    assert device_helpers.free_bytes(torch.device("meta")) is None
    with pytest.raises(ValueError, match=f"needs {2 * total} bytes"):
        device_helpers.check_fits(torch.device("cpu"), 2 * total, "a state")


def test_core_package_imports_without_torch():
    code = ("import sys; sys.modules['torch'] = None\n"
            "import numpy as np, qdensity\n"
            "from qdensity.execution.unary import forward\n"
            "from qdensity.execution.statevector.adjoint import AdjointEngine\n"
            "from qdensity.circuits.ansatze import pyramid\n"
            "print(forward(pyramid(3), np.eye(3)[0], np.zeros(3)).tolist())\n"
            "AdjointEngine()\n"
            "try:\n    AdjointEngine(backend='torch')\nexcept ImportError as e:\n"
            "    print('ImportError', 'qdensity[torch]' in str(e))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[:2] == ["[1.0, 0.0, 0.0]", "ImportError True"]


def test_pickles_carry_no_device_tensors():
    """The torch caches live beside the engine and the compiled circuit, not in them: a pickle
    written after a GPU run loads where no GPU is."""
    import pickle

    qc = hardware_efficient(3, 1)
    eng = AdjointEngine(backend="torch")
    eng.value_and_gradient(qc, "ZII", np.zeros((1, qc.num_parameters)))
    c = compile_unary(pyramid(4))
    forward(c, torch.zeros(2, 4, dtype=torch.float64), np.zeros(6))
    for obj in (eng, c):
        data = pickle.dumps(obj)
        assert b"_rebuild_tensor" not in data
        pickle.loads(data)
