"""Running quantum questions: plans (circuit templates, parameter rows, shots,
post-processing), engines that execute them (exact Aer probabilities, the adjoint statevector
engine with its gradients, any ``SamplerV2`` with a shot ledger, the unary engine of Supp. F),
shot schedulers for randomised density sampling (Fig. 1c). Targets, noise, transpilation,
resources and mitigation are the device's side: :mod:`qdensity.hardware`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from qdensity._lazy import lazy_exports

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
    "target_sampler",
]

#: public name -> the module that defines it, imported on first use (PEP 562)
_EXPORTS: dict[str, str] = {
    "ExactEngine": "qdensity.execution.exact",
    "CircuitJob": "qdensity.execution.plans",
    "Estimate": "qdensity.execution.plans",
    "JobResult": "qdensity.execution.plans",
    "Plan": "qdensity.execution.plans",
    "expectation_plan": "qdensity.execution.plans",
    "probabilities_plan": "qdensity.execution.plans",
    "SamplerEngine": "qdensity.execution.sampler.engine",
    "ShotLedger": "qdensity.execution.sampler.engine",
    "HammingWeightSampler": "qdensity.execution.samplers.hamming",
    "target_sampler": "qdensity.execution.samplers.target",
    "AdjointEngine": "qdensity.execution.statevector.adjoint",
}

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
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
    from qdensity.execution.samplers.hamming import HammingWeightSampler
    from qdensity.execution.samplers.target import target_sampler
    from qdensity.execution.statevector.adjoint import AdjointEngine


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
