"""HammingWeightSampler.defer: shots drawn when read, the same on every read, the law of run's
(for an integer seed run's very shots), and what SamplerEngine keeps until its post-processing
reads them."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from qiskit.circuit import ParameterVector, QuantumCircuit
from qiskit.primitives import BitArray

from qdensity import HammingWeightSampler, SamplerEngine
from qdensity.circuits.gates import RBSGate
from qdensity.execution.plans import CircuitJob
from qdensity.execution.sampler._packed_result import PackedJobResult, bitarray_to_bits
from qdensity.execution.samplers.hamming import DeferredSamples
from tests.execution.test_hamming_sampler import (
    ALPHA,
    _chi2_pvalue,
    _codes,
    _measured,
    _statevector_probs,
    random_circuit,
)


def _unary_template(n: int) -> QuantumCircuit:
    theta = ParameterVector("t", n - 1)
    qc = QuantumCircuit(n)
    qc.x(0)
    for j in range(n - 1):
        qc.append(RBSGate(theta[j]), [j, j + 1])
    qc.measure_all()
    return qc


@pytest.mark.parametrize("k", [1, 2])
@pytest.mark.parametrize("readout", [None, 0.05])
def test_an_integer_seed_defers_runs_very_shots(k, readout):
    qc = _measured(random_circuit(6, k, 3, parameterised=True))
    values = np.random.default_rng(1).uniform(-np.pi, np.pi, (3, qc.num_parameters))
    sampler = HammingWeightSampler(seed=11, readout_error=readout)
    ran = sampler.run([(qc, values, 200), (qc, values[:1], 50)]).result()
    later = sampler.defer([(qc, values, 200), (qc, values[:1], 50)])
    for res, d in zip(ran, later, strict=True):
        assert isinstance(d, DeferredSamples)
        bits = res.data.meas
        assert d.shape == bits.shape and d.num_shots == bits.num_shots
        assert d.num_bits == bits.num_bits
        np.testing.assert_array_equal(d.bitarray().array, bits.array)


def test_every_read_gives_the_same_shots_whatever_the_order():
    qc = _unary_template(5)
    values = np.random.default_rng(2).uniform(-np.pi, np.pi, (4, qc.num_parameters))
    gen = np.random.default_rng(7)
    a, b = HammingWeightSampler(seed=gen).defer([(qc, values, 100), (qc, values, 100)])
    second_first = b.packed().copy()
    first = a.packed().copy()
    np.testing.assert_array_equal(a.packed(), first)
    np.testing.assert_array_equal(b.packed(), second_first)
    assert not np.array_equal(first, second_first)  # two PUBs, two streams
    # a copy (pickled, as plans and results are) reads the same shots
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(a)).packed(), first)


@pytest.mark.parametrize("k", [1, 2])
def test_deferred_shots_follow_the_statevector(k):
    """Chi-square of the deferred counts against qiskit Statevector probabilities; a
    Generator seed (the engine's kind). False-failure rate ALPHA per case."""
    qc = random_circuit(7, k, 5, parameterised=True)
    values = np.random.default_rng(4).uniform(-np.pi, np.pi, (2, qc.num_parameters))
    (d,) = HammingWeightSampler(seed=np.random.default_rng(9)).defer(
        [(_measured(qc), values, 4000)])
    bits = bitarray_to_bits(d.bitarray(), 2, 4000)
    for r in range(2):
        counts = np.bincount(_codes(bits[r]), minlength=2**7)
        assert _chi2_pvalue(counts, _statevector_probs(qc, values[r])) > ALPHA


def test_defer_refuses_what_run_refuses_before_drawing():
    qc = QuantumCircuit(3)
    qc.h(0)
    qc.measure_all()
    with pytest.raises(ValueError, match="pub 0: .*'h'"):
        HammingWeightSampler(seed=0).defer([qc])
    with pytest.raises(ValueError, match="pub 0: "):  # 2 values per row for 3 parameters
        HammingWeightSampler(seed=0).defer([(_unary_template(4), np.zeros((1, 2)), 10)])
    with pytest.raises(ValueError, match="shots"):
        HammingWeightSampler(seed=0).defer([_unary_template(3)], shots=0)


def test_the_engine_keeps_shots_undrawn_until_read_and_counts_them_at_run():
    qc = _unary_template(6)
    values = np.random.default_rng(3).uniform(-np.pi, np.pi, (5, qc.num_parameters))
    engine = SamplerEngine(seed=4, progress=False)
    (res,) = engine.run([CircuitJob(qc, values, 300, "t")])
    assert isinstance(res, PackedJobResult)
    assert engine.ledger.total_shots == 5 * 300  # counted when run, not when read
    assert res.bits_shape == (5, 300, 6)
    first = res.bits.copy()
    shot, clbit = res.set_clbits()
    np.testing.assert_array_equal(res.bits, first)
    # the set bits are the bits' own, each shot of weight one (noiseless, unary)
    s2, c2 = np.nonzero(first.reshape(5 * 300, 6))
    np.testing.assert_array_equal(shot, s2)
    np.testing.assert_array_equal(clbit, c2)
    assert np.all(first.sum(axis=-1) == 1)
    # what the result holds between reads: the rows and the program, no shots
    (source, _, _) = res._packed
    assert not isinstance(source, BitArray)
    draw = source._draw
    held = [getattr(draw, name) for name in type(draw).__slots__
            if isinstance(getattr(draw, name), np.ndarray)]
    assert sum(a.nbytes for a in held) < first.size  # far below one shot per bit


def test_compiled_templates_live_as_long_as_their_circuits():
    """The sampler keeps a circuit's compiled template while the circuit lives (a second
    compile is the same object) and lets both go with it: plans rebuilt every training step
    leave nothing behind."""
    import gc
    import weakref

    sampler = HammingWeightSampler(seed=0)
    qc = _unary_template(5)
    first = sampler.compile(qc)
    assert sampler.compile(qc) is first
    gone = weakref.ref(qc)
    kept = [sampler.compile(_unary_template(4)) for _ in range(3)]  # circuits dropped at once
    del qc, first
    gc.collect()
    assert gone() is None
    assert len(sampler._compiled) == 0 and len(kept) == 3


def test_program_drawings_share_read_only_outcome_tables_equal_to_the_general_ones():
    """Drawings of precompiled programs (every qubit j into clbit j) hold one read-only set of
    outcome tables per width: equal to those the general path reads off the measured list,
    and the same arrays for every program of that width."""
    from qdensity import DensityQNN, Encoding, by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.execution.samplers._hamming_bits import clbits_of_qubits
    from qdensity.execution.samplers._hamming_draw import Draw
    from qdensity.execution.samplers._hamming_program import _Compiled
    from qdensity.gradients import density_gradient_plan

    n = 6
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       readout="unary_probabilities", seed=0)
    plan = density_gradient_plan(model, np.ones((2, n)), method="commuting", shots=10)
    draws = [Draw(_Compiled.from_program(job.program), job.values, 2, 10, None)
             for job in plan.jobs]
    for d in draws:
        np.testing.assert_array_equal(d.cols, np.arange(n))
        np.testing.assert_array_equal(d.table, clbits_of_qubits(list(range(n)), n))
        np.testing.assert_array_equal(d.outcome_qubits, np.arange(n)[:, None])
        for arr in (d.cols, d.table, d.outcome_qubits, d.probabilities.args[1]):
            assert not arr.flags.writeable
        assert d.cols is draws[0].cols and d.table is draws[0].table
    x = draws[0].probabilities.args[1]  # the input e_occupied, shared too
    np.testing.assert_array_equal(x, np.eye(n)[plan.jobs[0].program.occupied])
    assert all(d.probabilities.args[1] is x for d in draws)
