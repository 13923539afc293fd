"""The Hamming-weight sampler follows qiskit's sampler contract (compared against qiskit's own
``StatevectorSampler``), absorbs a final bit flip as the relabelling it is, and every seeded
sampler is reseeded through its ``with_seed`` (a seeded sampler without it is refused)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from _stats import stat_seed
from qiskit import QuantumCircuit
from qiskit.circuit import Gate, ParameterVector
from qiskit.exceptions import QiskitError
from qiskit.primitives import BaseSamplerV2, StatevectorSampler
from qiskit.quantum_info import Statevector

from qdensity.circuits.gates import RBSGate
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.plans import CircuitJob
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.samplers.hamming import HammingWeightSampler
from qdensity.execution.samplers.reseed import check_reseedable, reseeded, run_independent


def _chain(n: int = 4, weight: int = 1) -> QuantumCircuit:
    """``weight`` X gates, then RBS gates on neighbours (fixed angles) and a CZ."""
    qc = QuantumCircuit(n)
    for q in range(weight):
        qc.x(q)
    for j, t in zip(range(n - 1), (0.4, -0.9, 1.3, 0.2, 0.7), strict=False):
        qc.append(RBSGate(t), [j, j + 1])
    qc.cz(0, n - 1)
    return qc


def _counts(result, key: str = "meas") -> dict:
    return getattr(result[0].data, key).get_counts()


# -- qiskit's contract ---------------------------------------------------------------------


def test_bare_circuit_is_refused_as_qiskit_refuses_it():
    qc = _chain()
    qc.measure_all()
    with pytest.raises(ValueError, match="invalid Sampler pub-like") as ours:
        HammingWeightSampler(seed=1).run(qc)
    with pytest.raises(ValueError, match="invalid Sampler pub-like") as theirs:
        StatevectorSampler(seed=1).run(qc)
    assert type(ours.value) is type(theirs.value)
    assert "sampler.run([circuit])" in str(ours.value)


def test_circuit_without_registers_warns_and_gives_empty_data_as_qiskit():
    qc = _chain()
    with warnings.catch_warnings(record=True) as ours:
        warnings.simplefilter("always")
        res = HammingWeightSampler(seed=1).run([qc]).result()
    with warnings.catch_warnings(record=True) as theirs:
        warnings.simplefilter("always")
        ref = StatevectorSampler(seed=1).run([qc]).result()
    assert [(w.category, str(w.message)) for w in ours] == \
        [(w.category, str(w.message)) for w in theirs]
    assert len(ours) == 1 and ours[0].category is UserWarning
    assert len(res[0].data) == len(ref[0].data) == 0


def test_control_flow_is_a_qiskit_error_as_in_qiskit():
    qc = QuantumCircuit(2, 1)
    qc.x(0)
    qc.measure(0, 0)
    with qc.if_test((qc.clbits[0], 1)):
        qc.x(1)
    with pytest.raises(QiskitError):
        StatevectorSampler().run([qc]).result()
    with pytest.raises(QiskitError, match="classically controlled") as exc:
        HammingWeightSampler().run([qc])
    assert isinstance(exc.value, ValueError)  # qdensity's bad-input error too
    assert str(exc.value).startswith("pub 0: HammingWeightSampler cannot sample")


def test_weight_changing_gate_is_a_qiskit_error_and_a_value_error():
    qc = _chain()
    qc.h(1)
    qc.measure_all()
    with pytest.raises(QiskitError, match="'h'.*does not preserve") as exc:
        HammingWeightSampler().run([qc])
    assert isinstance(exc.value, ValueError)


# -- a final bit flip is a relabelling --------------------------------------------------------


class _FlipGate(Gate):
    """A custom one-qubit gate whose matrix is X up to phases (defined as Y then S twice)."""

    def __init__(self):
        super().__init__("myflip", 1, [])

    def _define(self):
        qc = QuantumCircuit(1)
        qc.y(0)
        qc.s(0)
        qc.s(0)
        self.definition = qc


FLIPS = {
    "x": lambda qc, q: qc.x(q),
    "y": lambda qc, q: qc.y(q),
    "rx_pi": lambda qc, q: qc.rx(np.pi, q),
    "custom": lambda qc, q: qc.append(_FlipGate(), [q]),
}


@pytest.mark.parametrize("flip", sorted(FLIPS))
@pytest.mark.parametrize("weight,readout", [(1, None), (2, None), (1, 0.1), (2, 0.05)])
def test_final_flip_gives_the_flipped_shots_of_the_circuit_without_it(flip, weight, readout):
    """Same seed: the shots of the circuit with final flips on qubits 1 and 3 are those of the
    circuit without them with clbits 1 and 3 inverted (a symmetric readout error acts on
    either value alike, so the identity holds with it too)."""
    plain = _chain(5, weight)
    plain.measure_all()
    flipped = _chain(5, weight)
    FLIPS[flip](flipped, 1)
    FLIPS[flip](flipped, 3)
    flipped.measure_all()
    a = HammingWeightSampler(seed=4, readout_error=readout).run([plain], shots=300).result()
    b = HammingWeightSampler(seed=4, readout_error=readout).run([flipped], shots=300).result()
    mask = np.uint8(0b01010)
    np.testing.assert_array_equal(b[0].data.meas.array, a[0].data.meas.array ^ mask)


def test_final_flip_samples_the_exact_distribution():
    """Against qiskit's exact probabilities of the same circuit (no shots): every outcome's
    frequency within 5 standard errors (false-failure rate below 32 x 5.7e-7 = 2e-5)."""
    qc = _chain(5, 2)
    qc.x(0)
    qc.y(4)
    exact = Statevector(qc).probabilities_dict()
    qc.measure_all()
    shots = 20000
    counts = _counts(HammingWeightSampler(seed=stat_seed(9)).run([qc], shots=shots).result())
    assert set(counts) <= {k for k, p in exact.items() if p > 1e-12}
    for key, p in exact.items():
        se = np.sqrt(max(p * (1 - p), 1e-12) / shots)
        assert abs(counts.get(key, 0) / shots - p) <= 5 * se + 1e-12, key


def test_fidelity_kernel_uncompute_ends_with_an_x_and_is_sampled():
    """``U(x1) U(x2)^dagger`` of unary loaders (compute-uncompute) ends with the X that
    loads qubit 0: absorbed, and ``P(0...0) = <x2|x1>^2`` within 5 standard errors."""
    x1 = np.array([0.3, -0.5, 0.7, 0.4])
    x2 = np.array([0.6, 0.1, -0.2, 0.75])
    kernel = unary_loader(x1).compose(unary_loader(x2).inverse())
    kernel.measure_all()
    shots = 20000
    counts = _counts(HammingWeightSampler(seed=stat_seed(3)).run([kernel], shots=shots)
                     .result())
    fidelity = (x1 @ x2) ** 2 / (x1 @ x1) / (x2 @ x2)
    freq = counts.get("0000", 0) / shots
    assert abs(freq - fidelity) <= 5 * np.sqrt(fidelity * (1 - fidelity) / shots)
    # the engine samples it exactly too, instead of sending it to Aer
    engine = SamplerEngine(seed=1, progress=False)
    engine.run([CircuitJob(kernel, None, 100)])
    assert engine.ledger.entries[-1].sampler == "hamming_weight"


def test_flip_of_a_measured_qubit_is_refused_and_flip_then_gate_is_refused():
    qc = _chain(3)
    qc.measure_all()
    qc.x(1)
    with pytest.raises(ValueError, match="after a measurement"):
        HammingWeightSampler().run([qc])
    qc = _chain(3)
    qc.x(2)
    qc.cz(1, 2)
    qc.measure_all()
    with pytest.raises(QiskitError, match="'cz'.*after the bit flip"):
        HammingWeightSampler().run([qc])


def test_engine_with_postselection_sends_a_flipped_template_to_aer():
    """A final flip moves outcomes off weight k: the engine's weight post-selection cannot
    read the circuit, so it is refused (as on Aer) rather than post-selected on weight k."""
    qc = _chain(3)
    qc.x(0)
    qc.measure_all()
    engine = SamplerEngine(seed=1, progress=False, postselect="hamming_weight")
    with pytest.raises(ValueError, match="Hamming"):
        engine.run([CircuitJob(qc, None, 50)])
    engine = SamplerEngine(seed=1, progress=False, postselect="hamming_weight",
                           hamming_weight="always")
    with pytest.raises(ValueError, match="bit flip before a measurement"):
        engine.run([CircuitJob(qc, None, 50)])


# -- reseeding -----------------------------------------------------------------------------


class _SeededNoReseed(BaseSamplerV2):
    """A new seeded sampler that does not say how to reseed itself."""

    def __init__(self, seed=5):
        self._inner = StatevectorSampler(seed=seed)

    @property
    def seed(self):
        return self._inner.seed

    def run(self, pubs, *, shots=None):
        return self._inner.run(pubs, shots=shots)


class _SeededWithReseed(_SeededNoReseed):
    seeds: list = []

    def with_seed(self, seed):
        type(self).seeds.append(seed)
        return _SeededWithReseed(seed)


def _pubs():
    qc = QuantumCircuit(3)
    qc.h(range(3))
    qc.measure_all()
    return [(qc, None, 64), (qc, None, 32)]  # two shot counts: two groups


def test_seeded_sampler_without_with_seed_is_refused():
    with pytest.raises(TypeError, match="with_seed"):
        SamplerEngine(sampler=_SeededNoReseed())
    with pytest.raises(TypeError, match="_SeededNoReseed.*with_seed"):
        run_independent(_SeededNoReseed(), _pubs())
    with pytest.raises(TypeError, match="with_seed"):
        check_reseedable(_SeededNoReseed(), "sampler")
    # unseeded: nothing to reseed, accepted
    check_reseedable(_SeededNoReseed(seed=None))
    SamplerEngine(sampler=_SeededNoReseed(seed=None))


def test_seeded_sampler_with_with_seed_is_reseeded_per_shot_group():
    _SeededWithReseed.seeds = []
    SamplerEngine(sampler=_SeededWithReseed())  # accepted
    res = run_independent(_SeededWithReseed(seed=5), _pubs())
    assert len(_SeededWithReseed.seeds) == 1 and _SeededWithReseed.seeds[0] != 5
    assert res[0].data.meas.num_shots == 64 and res[1].data.meas.num_shots == 32


def test_qiskit_and_hamming_samplers_are_reseedable():
    sv = reseeded(StatevectorSampler(seed=3, default_shots=77), 11)
    assert isinstance(sv, StatevectorSampler) and sv.seed == 11 and sv.default_shots == 77
    hw = reseeded(HammingWeightSampler(seed=3, readout_error=0.1, default_shots=9), 11)
    assert isinstance(hw, HammingWeightSampler) and hw.seed == 11
    assert hw.default_shots == 9 and hw.readout is not None
    assert reseeded(StatevectorSampler(), 11) is None  # unseeded: nothing to do
    # a seeded StatevectorSampler: the first shot group keeps the seed, the second draws
    # from another one (without reseeding it would repeat the seed's stream)
    theta = ParameterVector("t", 1)
    qc = QuantumCircuit(6)
    qc.h(range(6))
    qc.rz(theta[0], 0)
    qc.measure_all()
    rows = np.zeros((1, 1))
    a, b = run_independent(StatevectorSampler(seed=2), [(qc, rows, 200), (qc, rows, 100)])
    first = StatevectorSampler(seed=2).run([(qc, rows, 200)]).result()[0]
    unreseeded = StatevectorSampler(seed=2).run([(qc, rows, 100)]).result()[0]
    np.testing.assert_array_equal(a.data.meas.array, first.data.meas.array)
    assert not np.array_equal(b.data.meas.array, unreseeded.data.meas.array)
