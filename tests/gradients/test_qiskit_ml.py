"""qiskit-machine-learning trains on HammingWeightSampler with HammingShiftSamplerGradient.

Oracles: central finite differences of exact outcome probabilities
(``qiskit.quantum_info.Statevector``, RBS/FBS through their matrices); sampled gradients are
compared within a stated bound. Each estimate is ``sum_t w_t f_t`` over shifted circuits of
``S`` shots each, so its variance is at most ``sum_t w_t^2 / (4 S)``; the tests allow 5 times
that standard deviation (false-failure rate below 1e-6 per entry under the normal
approximation, with fixed seeds so a run repeats exactly).
"""

from __future__ import annotations

import numpy as np
import pytest
from qiskit import QuantumCircuit
from qiskit.circuit import Parameter, ParameterVector
from qiskit.primitives import BaseSamplerV2
from qiskit.quantum_info import Statevector
from qiskit_machine_learning.algorithms import NeuralNetworkClassifier
from qiskit_machine_learning.neural_networks import SamplerQNN
from qiskit_machine_learning.optimizers import ADAM

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.execution.samplers.hamming import HammingWeightSampler
from qdensity.gradients.qiskit_ml import HammingShiftSamplerGradient

SHOTS = 100_000
RBS_TERMS = np.array([1.0, 1.0, (np.sqrt(2) - 1) / 2, (np.sqrt(2) - 1) / 2])


def _model(n: int = 4) -> tuple[QuantumCircuit, ParameterVector, list[Parameter]]:
    """A unary model: X on qubit 0, data as RBS angles (a chain loader), a pyramid ansatz."""
    x = ParameterVector("x", n - 1)
    qc = QuantumCircuit(n)
    qc.x(0)
    for i in range(n - 1):
        qc.append(RBSGate(x[i]), [i, i + 1])
    ansatz = pyramid(n)
    qc.compose(ansatz, inplace=True)
    return qc, x, list(ansatz.parameters)


def _exact_probabilities(circuit: QuantumCircuit, values) -> np.ndarray:
    return Statevector(circuit.remove_final_measurements(inplace=False)
                       .assign_parameters(values)).probabilities()


def _finite_differences(circuit: QuantumCircuit, values, columns, h=1e-6) -> np.ndarray:
    """``(len(columns), 2**n)``: d p_k / d theta_j by central differences."""
    out = []
    for j in columns:
        e = np.zeros(len(values))
        e[j] = h
        out.append((_exact_probabilities(circuit, values + e)
                    - _exact_probabilities(circuit, values - e)) / (2 * h))
    return np.array(out)


def _dense(gradient: list[dict[int, float]], size: int) -> np.ndarray:
    out = np.zeros((len(gradient), size))
    for j, dist in enumerate(gradient):
        for k, v in dist.items():
            out[j, k] = v
    return out


def _shared_parameter_circuit() -> QuantumCircuit:
    """RBS, FBS across a qubit, a parameter in two gates (coefficients 2 and -1), an RZ."""
    a, b, c = Parameter("a"), Parameter("b"), Parameter("c")
    qc = QuantumCircuit(4)
    qc.x([0, 2])  # weight 2: FBS sees a set inner qubit
    qc.append(RBSGate(2 * a), [0, 1])
    qc.append(FBSGate(b, 3), [1, 2, 3])
    qc.append(RBSGate(-a + 0.3), [2, 3])
    qc.rz(c, 1)  # a relative phase that the later RBS on (0, 1) turns into probability
    qc.append(RBSGate(b), [0, 1])
    qc.measure_all()
    return qc


@pytest.mark.parametrize("seed", [1, 6])  # values where every row is far from zero
def test_gradient_matches_finite_differences_of_exact_probabilities(seed):
    qc = _shared_parameter_circuit()
    values = np.random.default_rng(seed).uniform(-np.pi, np.pi, qc.num_parameters)
    grad = HammingShiftSamplerGradient(HammingWeightSampler(seed=seed), {"shots": SHOTS})
    result = grad.run([qc], [values]).result()
    got = _dense(result.gradients[0], 2**qc.num_qubits)
    want = _finite_differences(qc, values, range(qc.num_parameters))
    # occurrences: a twice (|coefficients| 2 and 1), b twice, c once (rz: two terms, r = 1/2)
    bound = {"a": np.sqrt((4 + 1) * (RBS_TERMS**2).sum() / (4 * SHOTS)),
             "b": np.sqrt(2 * (RBS_TERMS**2).sum() / (4 * SHOTS)),
             "c": np.sqrt(2 * 0.25 / (4 * SHOTS))}
    for j, p in enumerate(qc.parameters):
        np.testing.assert_allclose(got[j], want[j], atol=5 * bound[p.name] + 1e-9,
                                   err_msg=p.name)
    assert min(np.abs(w).max() for w in want) > 0.05  # every row is a real test


def test_selected_parameters_and_many_samples_in_one_pub():
    qc, x, weights = _model(4)
    qc.measure_all()
    shots = 20_000
    rng = np.random.default_rng(3)
    values = rng.uniform(-np.pi, np.pi, (5, qc.num_parameters))
    pubs_seen = []

    class Recording(BaseSamplerV2):
        """Passes PUBs to a HammingWeightSampler and records their shapes."""

        def __init__(self):
            self.inner = HammingWeightSampler(seed=3)

        def run(self, pubs, *, shots=None):
            pubs_seen.append([np.asarray(p[1]).shape for p in pubs])
            return self.inner.run(pubs, shots=shots)

    grad = HammingShiftSamplerGradient(Recording(), {"shots": shots})
    result = grad.run([qc] * 5, values, parameters=[weights] * 5).result()
    # one sampler call, one PUB: 5 samples x 6 RBS weights x 4 terms rows
    assert pubs_seen == [[(5 * 6 * 4, qc.num_parameters)]]
    columns = [list(qc.parameters).index(w) for w in weights]
    sd = np.sqrt((RBS_TERMS**2).sum() / (4 * shots))
    for b in range(5):
        got = _dense(result.gradients[b], 16)
        want = _finite_differences(qc, values[b], columns)
        np.testing.assert_allclose(got, want, atol=5 * sd)
        assert set().union(*result.gradients[b]) <= {1, 2, 4, 8}  # unary outcomes only


def test_sampler_qnn_backward_with_input_gradients():
    qc, x, weights = _model(4)

    def interpret(k):
        return int(k >= 4)

    qnn = SamplerQNN(circuit=qc, input_params=list(x), weight_params=weights,
                     interpret=interpret, output_shape=2, input_gradients=True,
                     sampler=HammingWeightSampler(seed=5),
                     gradient=HammingShiftSamplerGradient(HammingWeightSampler(seed=6),
                                                          {"shots": SHOTS}))
    rng = np.random.default_rng(5)
    inputs, w = rng.uniform(0, np.pi, (2, 3)), rng.uniform(-np.pi, np.pi, len(weights))
    d_in, d_w = qnn.backward(inputs, w)
    sd = np.sqrt((RBS_TERMS**2).sum() / (4 * SHOTS))
    for b in range(2):
        values = np.concatenate([inputs[b], w])  # qc.parameters: x before θ
        fd = _finite_differences(qc, values, range(qc.num_parameters))
        # class 1 = outcomes 4 and 8 (qubits 2, 3); class 0 the rest
        ones = fd[:, [4, 8]].sum(axis=1)
        want = np.stack([fd.sum(axis=1) - ones, ones])  # (2 classes, parameters)
        np.testing.assert_allclose(d_in[b], want[:, :3], atol=2 * 5 * sd)
        np.testing.assert_allclose(d_w[b], want[:, 3:], atol=2 * 5 * sd)


def test_neural_network_classifier_trains_with_a_gradient_optimiser():
    n = 4
    qc, x, weights = _model(n)

    def interpret(k):
        return int(k >= 1 << (n // 2))

    rng = np.random.default_rng(0)
    inputs = rng.uniform(0, np.pi / 2, (24, n - 1))
    teacher = rng.uniform(-np.pi, np.pi, len(weights))
    p1 = np.array([_exact_probabilities(qc, np.concatenate([xi, teacher]))[[4, 8]].sum()
                   for xi in inputs])
    labels = (p1 > np.median(p1)).astype(int)
    qnn = SamplerQNN(circuit=qc, input_params=list(x), weight_params=weights,
                     interpret=interpret, output_shape=2,
                     sampler=HammingWeightSampler(seed=1, default_shots=2000),
                     gradient=HammingShiftSamplerGradient(HammingWeightSampler(seed=2),
                                                          {"shots": 2000}))
    losses: list[float] = []
    clf = NeuralNetworkClassifier(qnn, optimizer=ADAM(maxiter=30, lr=0.1),
                                  initial_point=np.random.default_rng(9).uniform(
                                      -np.pi, np.pi, len(weights)),
                                  callback=lambda *args: losses.append(float(args[-1])))
    clf.fit(inputs, labels)
    assert losses[-1] < 0.7 * losses[0]  # measured: 0.50 -> 0.25
    assert clf.score(inputs, labels) >= 0.8


def test_refuses_bad_sampler_and_unmeasured_circuits():
    with pytest.raises(TypeError, match="sampler"):
        HammingShiftSamplerGradient(object())
    qc, _, _ = _model(3)
    grad = HammingShiftSamplerGradient(HammingWeightSampler(seed=0))
    with pytest.raises(Exception, match="measures nothing"):
        grad.run([qc], [np.zeros(qc.num_parameters)]).result()
