"""Aer on GPU: runs only where qiskit-aer-gpu and a CUDA device are present."""

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import expectation_plan
from qdensity.hardware.targets import gpu_available

pytestmark = pytest.mark.skipif(not gpu_available(),
                                reason="needs qiskit-aer-gpu and a CUDA GPU (optional 'gpu' extra)")


def test_gpu_exact_engine_matches_cpu():
    circ = unary_loader(np.arange(1.0, 7.0)).compose(pyramid(6))
    obs = SparsePauliOp.from_sparse_list([("Z", [q], 1.0) for q in range(6)], 6)
    values = np.random.default_rng(0).uniform(-1, 1, (4, circ.num_parameters))
    plan = expectation_plan(circ, obs, values)
    cpu = plan.run(ExactEngine()).value
    gpu = plan.run(ExactEngine(device="GPU")).value
    np.testing.assert_allclose(gpu, cpu, atol=1e-10)
