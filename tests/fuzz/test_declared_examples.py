"""The argument-validation examples of issue "One contract for the public surface": each is
refused with a ValueError/TypeError that names the argument, before any work.

Oracles: what the issue says each call should not do (hang, allocate, accept silently), checked
by the exception class and the argument named in the message.
"""

from __future__ import annotations

import numpy as np
import pytest
from qiskit.circuit import Parameter, QuantumCircuit

from qdensity import DensityQNN, Encoding, GatedMixture, get_target
from qdensity.circuits.ansatze.hamming import pyramid
from qdensity.cluster import parse_cluster
from qdensity.execution.intervals import binomial_standard_error
from qdensity.execution.plans import CircuitJob
from qdensity_paper import run


@pytest.mark.parametrize("name", ["all_to_all", "rbs_native"])
def test_fully_connected_targets_are_bounded_before_building(name):
    with pytest.raises(ValueError, match=r"num_qubits must be <= 256"):
        get_target(name, 4096)


def test_run_refuses_a_billion_seeds_before_building_a_list():
    with pytest.raises(ValueError, match="seeds must be"):
        run("mixing-lemma", seeds=10**9, progress=False)


def test_circuit_job_refuses_complex_parameter_values():
    theta = Parameter("t")
    qc = QuantumCircuit(1, 1)
    qc.rx(theta, 0)
    qc.measure(0, 0)
    with pytest.raises(TypeError, match="values must be"):
        CircuitJob(qc, np.array([[0.5 + 0.25j]]))


def test_model_circuit_index_outside_the_sub_unitaries():
    model = DensityQNN([pyramid(3), pyramid(3, parameter_prefix="b")])
    with pytest.raises(ValueError, match="k must be"):
        model.circuit(-1)
    with pytest.raises(ValueError, match="k must be an int >= 0 and < K = 2"):
        model.circuit(2)


@pytest.mark.parametrize("p", [1.5, -0.1, [0.2, 1.01]])
def test_binomial_standard_error_refuses_frequencies_outside_0_1(p):
    with pytest.raises(ValueError, match="p must be frequencies in"):
        binomial_standard_error(p, 10)


def test_encoding_refuses_a_transform_that_is_not_callable_and_negative_features():
    qc = QuantumCircuit(4)
    with pytest.raises(TypeError, match="transform must be a callable"):
        Encoding(qc, "notcallable", 4)
    with pytest.raises(ValueError, match="num_features must be"):
        Encoding(qc, np.asarray, -1)


def test_a_gate_for_another_number_of_features_is_refused_when_the_model_is_built():
    with pytest.raises(ValueError, match="mixture must be a gate on the encoding's 4 features"):
        DensityQNN([pyramid(4)], GatedMixture(3, 1), encoding=Encoding.unary(4))


@pytest.mark.parametrize("address", ["local:99999999", "local:0", "local:-1"])
def test_parse_cluster_bounds_local_workers(address):
    with pytest.raises(ValueError, match="N in 'local:N' must be an int >= 1"):
        parse_cluster(address)


def test_torch_layer_refuses_input_whose_norm_overflows():
    torch = pytest.importorskip("torch")
    from qdensity.learning.torch import DensityQNNLayer

    model = DensityQNN([pyramid(3)], encoding=Encoding.unary(3),
                       readout="unary_probabilities", seed=0)
    layer = DensityQNNLayer(model)
    with pytest.raises(ValueError, match="input rows \\[0\\] are not finite or too large"):
        layer(torch.tensor([[1e300, 1.0, 1.0]], dtype=torch.float64))
    with pytest.raises(ValueError, match="input must be finite"):
        layer(torch.tensor([[float("nan"), 1.0, 1.0]], dtype=torch.float64))


def test_checks_left_to_the_declarations_still_refuse_and_numpy_ints_still_work():
    # the bodies of these callables no longer re-check seed / shots / widths / parameters
    from qiskit.circuit import ParameterVector

    from qdensity.analysis.blocks import commuting_blocks
    from qdensity.circuits.gates import RBSGate
    from qdensity.execution.samplers.hamming import HammingWeightSampler

    with pytest.raises(ValueError, match="seed must be an int >= 0"):
        HammingWeightSampler(seed=-1)
    with pytest.raises(TypeError, match="seed must be"):
        HammingWeightSampler(seed=True)
    with pytest.raises(ValueError, match="max_dimension must be"):
        HammingWeightSampler(max_dimension=0)
    sampler = HammingWeightSampler(default_shots=np.int64(5), max_dimension=np.int64(8))
    assert (type(sampler.default_shots), sampler.default_shots) == (int, 5)
    assert (type(sampler.max_dimension), sampler.max_dimension) == (int, 8)
    qc = QuantumCircuit(2)
    qc.x(0)
    qc.append(RBSGate(0.4), [0, 1])
    qc.measure_all()
    draws = [HammingWeightSampler(seed=s).run([qc], shots=50).result()[0].data.meas.get_counts()
             for s in (3, np.int64(3))]
    assert draws[0] == draws[1]  # a numpy int is the same seed as the int

    target = get_target("line", np.int64(3))
    assert (type(target.num_qubits), target.num_qubits) == (int, 3)
    with pytest.raises(ValueError, match="num_qubits must be"):
        get_target("line", 0)
    with pytest.raises(TypeError, match="basis_gates must be a list or tuple"):
        get_target("line", 3, basis_gates="cx")
    with pytest.raises(ValueError, match="basis_gates must be a list or tuple of 1 to 64"):
        get_target("line", 3, basis_gates=[])

    from qdensity.execution.statevector.adjoint import AdjointEngine

    with pytest.raises(ValueError, match="dtype must be one of 'complex128', 'complex64'"):
        AdjointEngine(backend="torch", dtype="complex32")  # refused before torch is needed

    theta = ParameterVector("t", 2)
    circuit = QuantumCircuit(2)
    circuit.ry(theta[0], 0)
    circuit.ry(theta[1], 1)
    with pytest.raises(TypeError, match="parameters must be"):
        commuting_blocks(circuit, ["t[0]"])
    with pytest.raises(TypeError, match="circuit must be"):
        commuting_blocks("circuit")
    # RY on two different qubits commute: one block over both gates (paper eq. 9)
    assert commuting_blocks(circuit, tuple(theta)) == [(0, 2)]
