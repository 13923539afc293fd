"""Gate-level circuits of the paper: RBS and FBS gates (:mod:`~.gates`, Supp. E), unary
loaders (:mod:`~.loaders`, Fig. 2), sub-unitary families (:mod:`~.ansatze`, Fig. 3, 4, 9,
Methods), the three density-state preparations (:mod:`~.preparation`, Fig. 1, 13b) and
l-infinity tomography of unary states (:mod:`~.tomography`, Supp. F)."""

from qdensity.circuits import ansatze
from qdensity.circuits.gates import FBSGate, RBSGate, fbs_matrix, rbs_matrix
from qdensity.circuits.loaders import (
    distribution_loader,
    loader_angles,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)
from qdensity.circuits.measure import measured

__all__ = [
    "RBSGate",
    "FBSGate",
    "rbs_matrix",
    "fbs_matrix",
    "unary_loader",
    "unary_loader_template",
    "loader_angles",
    "matrix_loader",
    "distribution_loader",
    "measured",
    "ansatze",
]
