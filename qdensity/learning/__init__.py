"""Training density QNNs: scikit-learn estimators (:mod:`~qdensity.learning.estimators`), the
quantum layer (:mod:`~qdensity.learning.layer`), the PyTorch module
(:mod:`~qdensity.learning.torch`, optional extra), optuna sweeps (:mod:`~qdensity.learning.sweep`,
optional extra), the numpy read-out and optimisers a density model needs on its own
(:mod:`~qdensity.learning.nn`, :mod:`~qdensity.learning.optim`, :mod:`~qdensity.learning.losses`)
and parameter files (:mod:`~qdensity.learning.parameters`); progress bars come from
:mod:`qdensity.progress`. :mod:`~qdensity.learning.training` keeps the first release's import
path."""

from qdensity.learning.estimators import QNNClassifier, QNNRegressor, UnscaledFeaturesWarning
from qdensity.learning.layer import History, QuantumLayer

__all__ = ["QuantumLayer", "History", "QNNClassifier", "QNNRegressor",
           "UnscaledFeaturesWarning"]
