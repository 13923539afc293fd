"""qdensity: density quantum neural networks on Qiskit and qiskit-aer.

The spine is ``circuits -> models -> plans -> engines -> training / experiments / CLI``.
"""

from .analysis import moments
from .gates import FBSGate, RBSGate

__version__ = "0.1.0"

__all__ = ["RBSGate", "FBSGate", "moments", "__version__"]
