"""Training density QNNs: scikit-learn estimators (:mod:`~.estimators`), the quantum layer
(:mod:`~.layer`), the PyTorch module (:mod:`~.torch`, optional extra), optuna sweeps
(:mod:`~.sweep`, optional extra), the numpy read-out and optimisers a density model needs on its
own (:mod:`~.nn`, :mod:`~.optim`, :mod:`~.losses`) and parameter files (:mod:`~.parameters`);
progress bars come from :mod:`qdensity.progress`. :mod:`~.training` keeps the first release's
import path."""

from qdensity.learning.estimators import QNNClassifier, QNNRegressor, UnscaledFeaturesWarning
from qdensity.learning.layer import History, QuantumLayer

__all__ = ["QuantumLayer", "History", "QNNClassifier", "QNNRegressor",
           "UnscaledFeaturesWarning"]
