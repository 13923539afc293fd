"""Every sampler and sampler engine survives ``pickle``, ``copy.deepcopy`` and scikit-learn's
``clone`` in any state (fresh, used) and behaves the same after the round trip: the copy and
the original draw the same shots for the same next run. Caches are rebuilt, not copied: 200
deep copies while other threads free compiled circuits (weak-reference callbacks firing) and
compile new ones never fail."""

from __future__ import annotations

import copy
import gc
import pickle
import threading

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector
from sklearn.base import clone

from qdensity.circuits.gates import RBSGate
from qdensity.execution.plans import CircuitJob
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.samplers import target_sampler
from qdensity.execution.samplers.hamming import HammingWeightSampler
from qdensity.hardware.targets import get_target


def _unary(n: int = 4, name: str = "unary") -> QuantumCircuit:
    """X on qubit 0 and a chain of parameterised RBS gates, measured."""
    theta = ParameterVector("t", n - 1)
    qc = QuantumCircuit(n, name=name)
    qc.x(0)
    for j in range(n - 1):
        qc.append(RBSGate(theta[j]), [j, j + 1])
    qc.measure_all()
    return qc


def _not_preserving(n: int = 3) -> QuantumCircuit:
    """A circuit the Hamming-weight sampler refuses (H): the engine sends it to Aer."""
    qc = QuantumCircuit(n, name="aer")
    qc.h(range(n))
    qc.measure_all()
    return qc


ROWS = np.array([[0.3, -0.7, 1.1], [1.2, 0.4, -0.2]])
ROUND_TRIPS = {
    "pickle": lambda obj: pickle.loads(pickle.dumps(obj)),
    "deepcopy": copy.deepcopy,
    "clone": lambda obj: clone(obj, safe=False),
}


def _bits(result) -> np.ndarray:
    return np.asarray(result[0].data.meas.array)


def _sampler_next(sampler) -> np.ndarray:
    pubs = [(_unary(), ROWS, 50)]
    return _bits(sampler.run(pubs).result())


def _engine_next(engine) -> list[np.ndarray]:
    jobs = [CircuitJob(_unary(), ROWS, 40, "hw"), CircuitJob(_not_preserving(), None, 30, "aer"),
            CircuitJob(_unary(), ROWS, 25, "hw2")]
    return [np.asarray(r.bits) for r in engine.run(jobs)]


def _used_sampler(seed):
    sampler = HammingWeightSampler(seed=seed, readout_error=0.05)
    circuits = [_unary(name=f"c{i}") for i in range(5)]  # several cached templates
    sampler.run([(c, ROWS, 10) for c in circuits]).result()
    return sampler, circuits


@pytest.mark.parametrize("trip", sorted(ROUND_TRIPS))
@pytest.mark.parametrize("seed", [7, "generator"])
@pytest.mark.parametrize("used", [False, True])
def test_hamming_sampler_round_trip_draws_the_same_shots(trip, seed, used):
    seed = np.random.default_rng(11) if seed == "generator" else seed
    if used:
        sampler, _keep = _used_sampler(seed)
    else:
        sampler = HammingWeightSampler(seed=seed, readout_error=0.05)
    twin = ROUND_TRIPS[trip](sampler)
    assert twin is not sampler
    assert twin.seed is not sampler.seed or isinstance(twin.seed, int)
    np.testing.assert_array_equal(_sampler_next(twin), _sampler_next(sampler))
    # a second run too: a Generator's stream continues identically on both
    np.testing.assert_array_equal(_sampler_next(twin), _sampler_next(sampler))


@pytest.mark.parametrize("trip", sorted(ROUND_TRIPS))
@pytest.mark.parametrize("used", [False, True])
def test_engine_round_trip_draws_the_same_shots_and_keeps_its_ledger(trip, used):
    engine = SamplerEngine(seed=5, progress=False)
    if used:
        _engine_next(engine)
    before = engine.ledger.total_shots
    twin = ROUND_TRIPS[trip](engine)
    assert twin.ledger is not engine.ledger and twin.ledger.total_shots == before
    for a, b in zip(_engine_next(twin), _engine_next(engine), strict=True):
        np.testing.assert_array_equal(a, b)
    assert twin.ledger.total_shots == engine.ledger.total_shots == before + 2 * 40 + 30 + 2 * 25
    # the Aer path and the Hamming-weight path were both taken
    assert {e.sampler for e in engine.ledger.entries} == {"hamming_weight", "AdaptiveSampler"}


@pytest.mark.parametrize("trip", sorted(ROUND_TRIPS))
def test_noisy_target_engine_and_its_aer_samplers_round_trip(trip):
    target = get_target("ring", 3, seed=2)
    for sampler in (target_sampler(target, seed=4),
                    target_sampler(target, seed=4, method="statevector")):
        qc = target.transpile(_not_preserving())
        first = sampler.run([(qc, None, 64)]).result()  # used: simulators built and cached
        twin = ROUND_TRIPS[trip](sampler)
        a = twin.run([(qc, None, 64)]).result()
        b = sampler.run([(qc, None, 64)]).result()
        np.testing.assert_array_equal(_bits(a), _bits(b))
        np.testing.assert_array_equal(_bits(a), _bits(first))  # a fixed seed repeats
    engine = SamplerEngine(target=target, seed=1, progress=False, hamming_weight="never")
    engine.run([CircuitJob(_unary(3), ROWS[:, :2], 20)])
    twin = ROUND_TRIPS[trip](engine)
    a = twin.run([CircuitJob(_unary(3), ROWS[:, :2], 20)])[0].bits
    b = engine.run([CircuitJob(_unary(3), ROWS[:, :2], 20)])[0].bits
    np.testing.assert_array_equal(a, b)


def test_pickled_engine_rebuilds_its_transpile_cache():
    engine = SamplerEngine(seed=2, progress=False, hamming_weight="never")
    engine.run([CircuitJob(_not_preserving(), None, 10)])
    assert engine.transpile_count == 1
    twin = pickle.loads(pickle.dumps(engine))
    assert twin.transpile_count == 0  # a cache: not carried
    twin.run([CircuitJob(_not_preserving(), None, 10)])
    assert twin.transpile_count == 1


@pytest.mark.parametrize("what", ["sampler", "engine"])
def test_concurrent_deepcopies_while_weakref_callbacks_fire(what):
    """200 deep copies while another thread compiles fresh circuits and drops them (each drop
    fires the cache's weak-reference callback, under ``gc.collect``): none may fail."""
    engine = SamplerEngine(seed=0, progress=False)
    engine.run([CircuitJob(_unary(), ROWS, 5)])
    sampler = HammingWeightSampler(seed=1)
    target = sampler if what == "sampler" else engine
    compile_with = sampler if what == "sampler" else engine._hamming()
    stop = threading.Event()
    errors: list[BaseException] = []

    def churn():
        try:
            while not stop.is_set():
                circuits = [_unary(3, name=f"tmp{i}") for i in range(8)]
                for c in circuits:
                    compile_with.compile(c)
                del circuits, c
                gc.collect()
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    workers = [threading.Thread(target=churn) for _ in range(2)]
    for w in workers:
        w.start()
    try:
        copies = [copy.deepcopy(target) for _ in range(200)]
    finally:
        stop.set()
        for w in workers:
            w.join()
    assert not errors
    assert len(copies) == 200
    # and the copies work: the same shots as their original's next run
    np.testing.assert_array_equal(_sampler_next(copies[-1]) if what == "sampler"
                                  else _engine_next(copies[-1])[0],
                                  _sampler_next(target) if what == "sampler"
                                  else _engine_next(target)[0])
