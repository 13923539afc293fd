"""The input classes of issue 42 item 7, each closed through the declarations and tried on every
declared callable: numpy scalars that mean a valid value are accepted (and reach the body as
that Python value), complex values are refused where the math is real, special files are
refused by every declared file path and every reader, ``.npy`` headers that claim more than
their member are refused before numpy allocates, public attributes are checked again when
they are assigned, and names are never paths.

Oracles: the declaration's own example (its numpy twins must satisfy it and normalise back
to it, equal in value and Python type), the same call made with Python values (same output),
the exception class and the argument named in its message, and ``tracemalloc`` peaks.
"""

from __future__ import annotations

import math
import os
import threading
import tracemalloc
import zipfile

import numpy as np
import pytest
from _api import declarations, public_callables

from qdensity.validation import (
    Array,
    FileName,
    FilePath,
    Instance,
    Interval,
    Options,
    Seed,
    Unchecked,
    check_distribution,
    check_finite_array,
)

PUBLIC = public_callables()
DECLARED = [(name, arg, c) for name, obj in PUBLIC.items()
            for arg, c in declarations(obj).items() if not isinstance(c, Unchecked)]

_INTS = (np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64)
_FLOATS = (np.float16, np.float32, np.float64)


def numpy_twins(value) -> list:
    """Numpy scalars of every dtype of ``value``'s kind that hold it exactly (a Python bool,
    int, float or str); none for anything else."""
    if isinstance(value, bool):
        return [np.bool_(value)]
    if isinstance(value, int):  # integer dtypes only: 2.0 is not a count, nor np.float32(2)
        return [t(value) for t in _INTS if np.iinfo(t).min <= value <= np.iinfo(t).max]
    if isinstance(value, float):
        return [t(value) for t in _FLOATS if float(t(value)) == value]
    if isinstance(value, str):
        return [np.str_(value)]
    return []


def _scalar_members(c):
    return [m for m in getattr(c, "members", [c]) if isinstance(m, (Interval, Options, Instance,
                                                                     Seed))]


SCALAR_CASES = []
for _name, _arg, _c in DECLARED:
    if not _scalar_members(_c):
        continue
    try:
        _example = _c.example()
    except LookupError:
        continue
    if numpy_twins(_example):
        SCALAR_CASES.append((_name, _arg, _c, _example))


def test_every_callable_with_a_scalar_argument_is_tried():
    assert len({n for n, *_ in SCALAR_CASES}) > 100


@pytest.mark.parametrize(("name", "arg", "c", "example"), SCALAR_CASES,
                         ids=[f"{n}:{a}" for n, a, *_ in SCALAR_CASES])
def test_numpy_scalars_meaning_a_valid_value_are_accepted_as_that_value(name, arg, c, example):
    for twin in numpy_twins(example):
        assert c.is_satisfied_by(twin), f"{name}: {arg}={twin!r} ({type(twin).__name__}) refused"
        body_gets = c.normalise(twin)
        assert body_gets == example and not isinstance(body_gets, np.generic), (
            f"{name}: {arg}={twin!r} reaches the body as {body_gets!r}")
        if isinstance(example, float):
            assert type(body_gets) is float
        elif isinstance(example, (bool, str)):
            assert type(body_gets) is type(example)


SEQUENCE_CASES = []
for _name, _arg, _c in DECLARED:
    _members = [m for m in getattr(_c, "members", [_c]) if hasattr(m, "item")
                and isinstance(m.item, (Interval, Options))]
    for _m in _members:
        try:
            _example = _m.example()
        except LookupError:
            continue
        if _example and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                            for v in _example):
            SEQUENCE_CASES.append((_name, _arg, _c, list(_example)))


@pytest.mark.parametrize(("name", "arg", "c", "example"), SEQUENCE_CASES,
                         ids=[f"{n}:{a}" for n, a, *_ in SEQUENCE_CASES])
def test_numpy_arrays_of_valid_items_are_accepted_as_lists(name, arg, c, example):
    kinds = _INTS if isinstance(example[0], int) else _FLOATS
    for t in kinds:
        arr = np.array(example).astype(t)
        if arr.tolist() != example:
            continue  # this dtype cannot hold the values
        assert c.is_satisfied_by(arr), f"{name}: {arg}={arr!r} refused"
        body_gets = c.normalise(arr)
        assert body_gets == example and all(not isinstance(v, np.generic) for v in body_gets)


def test_numpy_scalars_give_the_same_results_as_python_values():
    from qdensity import DensityQNN, FixedMixture
    from qdensity.circuits.ansatze.hamming import pyramid
    from qdensity.circuits.tomography.bounds import shots_for_error

    def gates(qc):  # circuits of fresh Parameters compare by their gates and parameter names
        return [(i.operation.name, [qc.find_bit(q).index for q in i.qubits],
                 [str(p) for p in i.operation.params]) for i in qc.data]

    assert gates(pyramid(np.int64(4))) == gates(pyramid(4))
    assert gates(pyramid(np.uint8(3))) == gates(pyramid(3))
    assert shots_for_error(np.float32(0.25), np.uint16(8), np.float64(0.01)) == shots_for_error(
        float(np.float32(0.25)), 8, 0.01)
    weights = np.full(3, 1 / 3, dtype=np.float32)  # sums to 1 within float32, not within 1e-9
    subs = [pyramid(3, parameter_prefix=p) for p in "abc"]
    model = DensityQNN(subs, FixedMixture(weights), seed=np.int64(3))
    twin = DensityQNN(subs, FixedMixture(weights.astype(float) / weights.astype(float).sum()),
                      seed=3)
    np.testing.assert_allclose(model.predict(), twin.predict(), atol=1e-6)
    assert gates(model.circuit(np.uint8(1))) == gates(model.circuit(1))


def test_an_estimator_with_numpy_hyperparameters_fits_and_saves_as_with_python_ones(tmp_path):
    from qdensity.learning.estimators import QNNClassifier

    X = np.random.default_rng(0).normal(size=(12, 2))
    y = (X[:, 0] > 0).astype(int)
    numpy_clf = QNNClassifier(num_qubits=np.uint8(2), epochs=np.int64(2), batch_size=np.int32(4),
                              seed=np.uint32(5), verbose=False).fit(X, y)
    python_clf = QNNClassifier(num_qubits=2, epochs=2, batch_size=4, seed=5,
                               verbose=False).fit(X, y)
    np.testing.assert_array_equal(numpy_clf.predict_proba(X), python_clf.predict_proba(X))
    for suffix in (".json", ".npz"):
        numpy_clf.save(tmp_path / f"clf{suffix}")
        loaded = QNNClassifier().load(tmp_path / f"clf{suffix}")
        np.testing.assert_array_equal(loaded.predict_proba(X), python_clf.predict_proba(X))


def test_weights_sum_to_one_within_their_own_precision():
    for dtype in (np.float16, np.float32):
        w = np.full(7, 1 / 7, dtype=dtype)
        assert abs(float(w.astype(float).sum()) - 1) > 1e-9  # the old tolerance refused it
        np.testing.assert_array_equal(check_distribution(w), w.astype(float))
    with pytest.raises(ValueError, match="alpha must sum to 1"):
        check_distribution(np.array([0.5, 0.49], dtype=np.float32))


# ------------------------------------------------------------------ complex where math is real

REAL_ARRAYS = [(n, a, c) for n, a, c in DECLARED
               for m in getattr(c, "members", [c])
               if isinstance(m, Array) and m.dtype in ("real", "int")]


@pytest.mark.parametrize(("name", "arg", "c"), REAL_ARRAYS,
                         ids=[f"{n}:{a}" for n, a, _ in REAL_ARRAYS])
def test_complex_values_are_refused_where_the_math_is_real(name, arg, c):
    for m in getattr(c, "members", [c]):
        if isinstance(m, Array) and m.dtype in ("real", "int"):
            good = np.asarray(m.example())
            assert not c.is_satisfied_by(good.astype(complex)), (
                f"{name}: {arg} accepts a complex array (zero imaginary parts)")
            assert not c.is_satisfied_by(good.astype(complex) + 0.5j)


def test_complex_data_and_angles_are_refused_not_cut_to_their_real_part():
    from qdensity import DensityQNN, Encoding
    from qdensity.circuits.ansatze.hamming import pyramid

    model = DensityQNN([pyramid(4)], encoding=Encoding.unary(4), seed=0)
    X = np.array([[0.1, 0.2, 0.3, 0.4]])
    with pytest.raises(TypeError, match="theta must be real"):
        model.theta = model.theta + 0j
    with pytest.raises(TypeError, match="theta must be real"):
        model.predict(X, model.theta.astype(complex))
    with pytest.raises(TypeError, match="X must be real"):
        model.predict(X + 0.5j)
    with pytest.raises(TypeError, match="values must be real"):
        check_finite_array([1.0, 2.0 + 0j], "values")


# ------------------------------------------------------------------ special files and sizes

def _fifo(tmp_path):
    path = tmp_path / "fifo"
    os.mkfifo(path)
    return path


FILE_ARGS = [(n, a, c) for n, a, c in DECLARED for m in getattr(c, "members", [c])
             if isinstance(m, FilePath) and m.exists == "file"]


@pytest.mark.parametrize(("name", "arg", "c"), FILE_ARGS,
                         ids=[f"{n}:{a}" for n, a, _ in FILE_ARGS])
def test_declared_files_refuse_devices_and_fifos(name, arg, c, tmp_path):
    for special in ("/dev/zero", os.devnull, _fifo(tmp_path)):
        assert not c.is_satisfied_by(special), f"{name}: {arg} accepts {special}"


def _finishes(fn, seconds: float = 60.0):
    """``fn()``'s exception, from a thread that must finish within ``seconds`` (a reader that
    opens a FIFO would block forever)."""
    out: list = []

    def run():
        try:
            fn()
            out.append(None)
        except BaseException as exc:  # noqa: BLE001 - handed to the test
            out.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(seconds)
    assert not worker.is_alive(), "the reader blocked"
    return out[0]


def _readers():
    from qdensity.datasets.mnist import load_mnist, read_idx
    from qdensity.hardware.snapshot_files import load_snapshot
    from qdensity.learning.estimators import QNNClassifier
    from qdensity.learning.parameters import load_parameters

    return {"load_parameters": load_parameters, "QNNClassifier.load": QNNClassifier().load,
            "load_snapshot": load_snapshot, "read_idx": read_idx,
            "load_mnist": lambda p: load_mnist(p)}


@pytest.mark.parametrize("reader", ["load_parameters", "QNNClassifier.load", "load_snapshot",
                                    "read_idx", "load_mnist"])
def test_readers_refuse_special_files_before_reading(reader, tmp_path):
    read = _readers()[reader]
    for special in ("/dev/zero", _fifo(tmp_path)):
        exc = _finishes(lambda s=special: read(s))
        assert isinstance(exc, (ValueError, TypeError)), f"{reader}({special}): {exc!r}"
        assert str(special) in str(exc) or "path" in str(exc)


def _npz_claiming(path, shape=(10**12,)):
    """An .npz whose one member holds a 16-byte payload under a header claiming ``shape``."""
    import io

    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False,
                                                  "shape": shape})
    member.write(b"\0" * 16)
    with zipfile.ZipFile(path, "w") as zf:
        for key in ("x_train", "y_train", "x_test", "y_test"):
            zf.writestr(f"{key}.npy", member.getvalue())
    return path


@pytest.mark.parametrize("reader", ["load_parameters", "load_mnist"])
def test_npy_headers_claiming_more_than_their_member_are_refused_unallocated(reader, tmp_path):
    path = _npz_claiming(tmp_path / "huge.npz")
    read = _readers()[reader]
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"huge\.npz.*claims shape \(1000000000000,\)"):
            read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * 2**20


# ------------------------------------------------------------------ public attributes

def test_every_declared_class_checks_its_public_attributes_on_assignment():
    classes = [obj for name, obj in PUBLIC.items() if isinstance(obj, type)
               and "__constraints__" in vars(obj)
               and any(not k.startswith("_") and not isinstance(c, Unchecked)
                       for k, c in declarations(obj).items())]
    assert len(classes) > 20
    unchecked = [c.__qualname__ for c in classes
                 if getattr(c.__setattr__, "__qualname__", "") != f"{c.__qualname__}.__setattr__"]
    assert not unchecked


def test_an_invalid_attribute_is_refused_when_assigned_and_a_valid_one_is_used():
    from qdensity import DensityQNN, Encoding, SamplerEngine
    from qdensity.circuits.ansatze.hamming import pyramid

    model = DensityQNN([pyramid(4)], encoding=Encoding.unary(4), seed=0)
    X = np.array([[0.1, 0.2, 0.3, 0.4]])
    with pytest.raises(ValueError, match="readout must be one of"):
        model.readout = "bogus"
    assert model.predict(X).shape == (1,)
    model.readout = "unary_probabilities"  # valid: read by the next predict
    probs = model.predict(X)
    assert probs.shape == (1, 4) and probs.sum() == pytest.approx(1.0)
    engine = SamplerEngine(default_shots=100)
    for bad, error in ((0, ValueError), (2.5, TypeError), ("many", TypeError)):
        with pytest.raises(error, match="default_shots"):
            engine.default_shots = bad
    engine.default_shots = np.int64(200)
    assert type(engine.default_shots) is int and engine.default_shots == 200
    from qdensity.learning.layer import QuantumLayer

    layer = QuantumLayer(model, "exact")
    with pytest.raises(ValueError, match="shots must be an int >= 2"):
        layer.shots = -1
    with pytest.raises(TypeError, match="engine must be 'exact' or"):
        layer.engine = 3


# ------------------------------------------------------------------ names are never paths

@pytest.mark.parametrize("name", ["../x", "a/b", "/etc/passwd", "..", ".hidden", "a\\b",
                                  "a\0b", ""])
def test_a_name_is_never_a_path(name):
    assert not FileName().is_satisfied_by(name)
    assert FileName().is_satisfied_by("pyramid-shots-paper_t3.v2")


# ------------------------------------------------------------------ tolerances at the extremes

@pytest.mark.parametrize("delta", [5e-324, 1e-300, 1e-160, 1e-3])
def test_a_tiny_tolerance_is_refused_not_overflowed(delta):
    from qdensity.circuits.tomography.bounds import SIGN_FACTOR, shots_for_error

    # the oracle: N = (1 + 4 sqrt 2)^2 ln(6 n / p_fail) / delta^2 shots, in logarithms
    log_needed = 2 * math.log(SIGN_FACTOR) + math.log(math.log(6 * 4 / 0.01)) - 2 * math.log(
        delta)
    assert log_needed > math.log(10**8)
    with pytest.raises(ValueError, match="delta must be >= 0.00186"):
        shots_for_error(delta, 4, 0.01)


@pytest.mark.parametrize("delta", [1e154, 1e300, 1.7e308])
def test_a_huge_tolerance_needs_one_shot(delta):
    from qdensity.circuits.tomography.bounds import shots_for_error

    assert shots_for_error(delta, 4, 0.01) == 1


# ------------------------------------------------------------------ widths and totals bounded

def test_a_forced_mps_run_of_unbounded_entanglement_is_refused_before_aer():
    from qiskit import QuantumCircuit

    from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY, check_memory

    n = 40  # a dense state of 40 qubits takes 16 TiB: only a bounded MPS may run
    chain, spread = QuantumCircuit(n, n), QuantumCircuit(n, n)
    chain.h(0)
    for q in range(n - 1):  # neighbours on the line: bond dimension 2 (mps_bond_bound)
        chain.cx(q, q + 1)
    spread.h(0)
    for q in range(1, n):  # all from qubit 0: no neighbour bound
        spread.cx(0, q)
    check_memory(n, "matrix_product_state", "test", chain)
    with pytest.raises(ValueError, match="no proven bond bound"):
        check_memory(n, "matrix_product_state", "test", spread)
    spread.metadata = {HAMMING_WEIGHT_KEY: 1}  # weight 1: Schmidt rank <= 2 on every cut
    check_memory(n, "matrix_product_state", "test", spread)


def test_a_unary_circuit_beyond_the_gate_bound_is_refused_before_compiling(monkeypatch):
    import qdensity.execution.unary as unary
    from qdensity.circuits.ansatze.hamming import pyramid

    monkeypatch.setattr(unary, "MAX_UNARY_GATES", 14)
    assert unary.compile_unary(pyramid(5)).num_gates == 10  # n(n-1)/2 gates
    with pytest.raises(ValueError, match="circuit has 15 instructions, more than the 14"):
        unary.compile_unary(pyramid(6))  # 6 * 5 / 2 = 15


def test_a_plan_bounds_its_total_shots():
    from qiskit import QuantumCircuit

    from qdensity.execution.plans import CircuitJob, Plan
    from qdensity.validation import MAX_PLAN_SHOTS

    qc = QuantumCircuit(1, 1)
    qc.measure(0, 0)
    job = CircuitJob(qc, np.zeros((1000, 0)), shots=200_000)  # 2e8 shots: within one job
    jobs = MAX_PLAN_SHOTS // (1000 * 200_000)
    assert Plan([job] * jobs, list).total_shots == MAX_PLAN_SHOTS
    with pytest.raises(ValueError, match="jobs must ask for at most"):
        Plan([job] * (jobs + 1), list)
    with pytest.raises(ValueError, match="jobs must ask for at most"):
        Plan([job.__class__(qc, np.zeros((1000, 0)), shots=1)] * (jobs + 1), list).with_shots(
            200_000)


def test_a_model_without_an_encoding_refuses_columns_it_would_ignore():
    from qdensity import DensityQNN, GatedMixture
    from qdensity.circuits.ansatze.hamming import pyramid

    model = DensityQNN([pyramid(3)], seed=0)  # no encoding, no uploaded x[i]: takes no data
    with pytest.raises(ValueError, match=r"X must have shape \(rows >= 1, 0\).*pass X=None"):
        model.predict(np.ones((2, 5)))
    assert model.predict().shape == (1,)
    gated = DensityQNN([pyramid(3), pyramid(3, parameter_prefix="b")],
                       GatedMixture(num_features=4, num_components=2, seed=0), seed=0)
    X = np.random.default_rng(1).normal(size=(3, 4))  # the gate reads these columns
    alpha = gated.alpha(X)
    np.testing.assert_allclose(gated.predict(X), (alpha * gated.expert_outputs(None)).sum(axis=1))
    with pytest.raises(ValueError, match=r"X must have shape \(rows >= 1, 4\)"):
        gated.predict(np.ones((3, 5)))
