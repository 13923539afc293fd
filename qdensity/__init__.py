"""qdensity: density quantum neural networks on Qiskit and qiskit-aer.

``circuits`` (gates, loaders, ansatze, preparations, tomography) make ``models`` (DensityQNN,
mixtures, decompositions), which compile questions to plans that ``execution`` runs (engines,
schedulers, targets); ``gradients``, ``learning``, ``experiments`` and ``cli`` build on them,
``analysis`` and ``datasets`` lie underneath. Imports only go down this list (CONTRIBUTING.md).
"""

from qdensity import _aliases
from qdensity.analysis.structure import is_hamming_weight_preserving, moments
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.circuits.loaders import (
    distribution_loader,
    loader_angles,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)
from qdensity.execution.engines import ExactEngine, SamplerEngine, ShotLedger
from qdensity.execution.plans import Plan, expectation_plan, probabilities_plan
from qdensity.execution.resources import compare_reports, resource_report
from qdensity.execution.targets import get_target, known_targets
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

_aliases.install()

__version__ = "0.1.0"

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
    "get_target",
    "known_targets",
    "resource_report",
    "compare_reports",
    "QNNClassifier",
    "QNNRegressor",
    "__version__",
]


def __getattr__(name: str):
    """``qdensity.ansatze`` and the other short module paths resolve without an explicit import."""
    real = _aliases.resolve(f"qdensity.{name}")
    if real is None:
        raise AttributeError(f"module 'qdensity' has no attribute {name!r}")
    import importlib

    return importlib.import_module(f"qdensity.{name}")
