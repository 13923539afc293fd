"""qdensity: density quantum neural networks on Qiskit and qiskit-aer.

The spine is ``circuits -> models -> plans -> engines -> training / experiments / CLI``:

* circuits: :mod:`qdensity.gates` (RBS, FBS), :mod:`qdensity.loaders`,
  :mod:`qdensity.ansatze`, :mod:`qdensity.preparation`, :mod:`qdensity.tomography`;
* models: :class:`DensityQNN`, :mod:`qdensity.mixtures`, :mod:`qdensity.decompositions`;
* plans and engines: :mod:`qdensity.plans`, :mod:`qdensity.engines`, :mod:`qdensity.unary`;
* gradients and training: :mod:`qdensity.gradients`, :mod:`qdensity.training`;
* hardware: :mod:`qdensity.targets`, :mod:`qdensity.noise`, :mod:`qdensity.resources`.
"""

from .analysis import is_hamming_weight_preserving, moments
from .decompositions import Decomposition, by_moments, copies, cyclic_moments, odd_even
from .engines import ExactEngine, SamplerEngine, ShotLedger
from .gates import FBSGate, RBSGate
from .loaders import (
    distribution_loader,
    loader_angles,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)
from .mixtures import FixedMixture, GatedMixture, SoftmaxMixture
from .models import DensityQNN, Encoding
from .plans import Plan, expectation_plan, probabilities_plan
from .resources import compare_reports, resource_report
from .targets import get_target, known_targets
from .training import QNNClassifier, QNNRegressor

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
