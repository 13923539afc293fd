"""Training density QNNs: scikit-learn style estimators and the quantum layer
(:mod:`~.training`), classical layers for hybrid models (:mod:`~.nn`, Fig. 11), flat parameter
vectors and parameter files (:mod:`~.parameters`), losses and optimisers."""

from qdensity.learning.training import History, QNNClassifier, QNNRegressor, QuantumLayer

__all__ = ["QuantumLayer", "History", "QNNClassifier", "QNNRegressor"]
