"""Training density QNNs: the quantum layer and the scikit-learn estimators, in one place.

This module keeps the import path of the first release. The pieces live in:

* :mod:`qdensity.learning.layer` -- :class:`QuantumLayer` (a :class:`DensityQNN` with
  ``forward`` / ``backward``: exact unary reverse mode, or gradient plans through any engine
  with shots on the ledger) and :class:`History`;
* :mod:`qdensity.learning.estimators` -- :class:`QNNClassifier` and :class:`QNNRegressor`,
  scikit-learn estimators (``clone``, ``Pipeline``, ``GridSearchCV``, ``check_estimator``);
* :mod:`qdensity.learning.torch` -- the PyTorch module (optional extra ``qdensity[torch]``).
"""

from qdensity.learning.estimators import QNNClassifier, QNNRegressor
from qdensity.learning.layer import BudgetExhausted, History, QuantumLayer

__all__ = ["QuantumLayer", "History", "QNNClassifier", "QNNRegressor", "BudgetExhausted"]
