"""qdensity: density quantum neural networks on Qiskit and qiskit-aer.

``circuits`` (gates, loaders, ansatze, preparations, tomography) make ``models`` (DensityQNN,
mixtures, decompositions), which compile questions to plans that ``execution`` runs (engines,
schedulers) on the devices of ``hardware`` (targets, noise, transpilation, mitigation);
``gradients``, ``learning``, ``demo`` and ``cli`` build on them (the paper's experiments live
in the separate ``qdensity_paper`` package, which uses only this public API),
``analysis`` and ``datasets`` lie underneath. Imports only go down this list (CONTRIBUTING.md).

The names below are loaded on first use (PEP 562), so ``import qdensity`` and the command line
start without importing scikit-learn, Aer or the subpackages a task does not touch;
``from qdensity import DensityQNN`` works as usual.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: public name -> the module that defines it
_EXPORTS: dict[str, str] = {
    "RBSGate": "qdensity.circuits.gates",
    "FBSGate": "qdensity.circuits.gates",
    "moments": "qdensity.analysis.structure",
    "is_hamming_weight_preserving": "qdensity.analysis.structure",
    "unary_loader": "qdensity.circuits.loaders",
    "unary_loader_template": "qdensity.circuits.loaders",
    "loader_angles": "qdensity.circuits.loaders",
    "matrix_loader": "qdensity.circuits.loaders",
    "distribution_loader": "qdensity.circuits.loaders",
    "DensityQNN": "qdensity.models.density",
    "Encoding": "qdensity.models.density",
    "FixedMixture": "qdensity.models.mixtures",
    "SoftmaxMixture": "qdensity.models.mixtures",
    "GatedMixture": "qdensity.models.mixtures",
    "Decomposition": "qdensity.models.decompositions",
    "by_moments": "qdensity.models.decompositions",
    "cyclic_moments": "qdensity.models.decompositions",
    "odd_even": "qdensity.models.decompositions",
    "copies": "qdensity.models.decompositions",
    "Plan": "qdensity.execution.plans",
    "expectation_plan": "qdensity.execution.plans",
    "probabilities_plan": "qdensity.execution.plans",
    "ExactEngine": "qdensity.execution.exact",
    "SamplerEngine": "qdensity.execution.sampler.engine",
    "ShotLedger": "qdensity.execution.sampler.engine",
    "HammingWeightSampler": "qdensity.execution.samplers.hamming",
    "target_sampler": "qdensity.execution.samplers.target",
    "get_target": "qdensity.hardware.targets",
    "known_targets": "qdensity.hardware.targets",
    "resource_report": "qdensity.hardware.resources",
    "compare_reports": "qdensity.hardware.resources",
    "QNNClassifier": "qdensity.learning.estimators",
    "QNNRegressor": "qdensity.learning.estimators",
}

__all__ = [
    "RBSGate",
    "FBSGate",
    "moments",
    "is_hamming_weight_preserving",
    "unary_loader",
    "unary_loader_template",
    "loader_angles",
    "matrix_loader",
    "distribution_loader",
    "DensityQNN",
    "Encoding",
    "FixedMixture",
    "SoftmaxMixture",
    "GatedMixture",
    "Decomposition",
    "by_moments",
    "cyclic_moments",
    "odd_even",
    "copies",
    "Plan",
    "expectation_plan",
    "probabilities_plan",
    "ExactEngine",
    "SamplerEngine",
    "ShotLedger",
    "HammingWeightSampler",
    "target_sampler",
    "get_target",
    "known_targets",
    "resource_report",
    "compare_reports",
    "QNNClassifier",
    "QNNRegressor",
    "__version__",
]  # the names of _EXPORTS, spelled out for linters

_SUBMODULES = frozenset({"analysis", "circuits", "cli", "cluster", "datasets", "demo", "execution",
                         "gradients", "hardware", "learning", "models", "progress", "validation"})

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
    from qdensity.analysis.structure import is_hamming_weight_preserving, moments
    from qdensity.circuits.gates import FBSGate, RBSGate
    from qdensity.circuits.loaders import (
        distribution_loader,
        loader_angles,
        matrix_loader,
        unary_loader,
        unary_loader_template,
    )
    from qdensity.execution.exact import ExactEngine
    from qdensity.execution.plans import Plan, expectation_plan, probabilities_plan
    from qdensity.execution.sampler.engine import SamplerEngine, ShotLedger
    from qdensity.execution.samplers.hamming import HammingWeightSampler
    from qdensity.execution.samplers.target import target_sampler
    from qdensity.hardware.resources import compare_reports, resource_report
    from qdensity.hardware.targets import get_target, known_targets
    from qdensity.learning.estimators import QNNClassifier, QNNRegressor
    from qdensity.models.decompositions import (
        Decomposition,
        by_moments,
        copies,
        cyclic_moments,
        odd_even,
    )
    from qdensity.models.density import DensityQNN, Encoding
    from qdensity.models.mixtures import FixedMixture, GatedMixture, SoftmaxMixture


def _load(name: str):
    """Public names load their module on first use; the subpackages resolve without an explicit
    import (``qdensity.circuits.ansatze``)."""
    module = _EXPORTS.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
        globals()[name] = value  # later lookups skip this function
        return value
    if name not in _SUBMODULES:
        raise AttributeError(f"module 'qdensity' has no attribute {name!r}")
    return importlib.import_module(f"qdensity.{name}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__ = _load
