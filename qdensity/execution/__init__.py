"""Running quantum questions: plans (circuit templates, parameter rows, shots,
post-processing), engines that execute them (exact Aer probabilities, the adjoint statevector
engine with its gradients, any ``SamplerV2`` with a shot ledger, the unary engine of Supp. F),
shot schedulers for randomised density sampling (Fig. 1c). Targets, noise, transpilation,
resources and mitigation are the device's side: :mod:`qdensity.hardware`."""

from qdensity.execution.exact import ExactEngine
from qdensity.execution.plans import (
    CircuitJob,
    Estimate,
    JobResult,
    Plan,
    expectation_plan,
    probabilities_plan,
)
from qdensity.execution.sampler.engine import SamplerEngine, ShotLedger
from qdensity.execution.sampler.hamming import HammingWeightSampler
from qdensity.execution.statevector.adjoint import AdjointEngine

__all__ = [
    "CircuitJob",
    "JobResult",
    "Plan",
    "Estimate",
    "expectation_plan",
    "probabilities_plan",
    "ExactEngine",
    "AdjointEngine",
    "SamplerEngine",
    "ShotLedger",
    "HammingWeightSampler",
]
