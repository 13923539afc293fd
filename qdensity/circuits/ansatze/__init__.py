"""Parameterised sub-unitary families (paper Fig. 3, 4, 9 and Methods), and their registry by
name (:mod:`~qdensity.circuits.ansatze.registry`) that the estimators and the CLI read."""

from qdensity.circuits.ansatze.equivariant import (
    angle_encoding,
    bars_and_dots,
    equivariant_commuting,
    equivariant_noncommuting,
    equivariant_observable,
    translation_classes,
)
from qdensity.circuits.ansatze.hamming import (
    butterfly,
    pairs_circuit,
    pyramid,
    round_robin,
    round_robin_pairs,
    x_circuit,
)
from qdensity.circuits.ansatze.hardware_efficient import hardware_efficient
from qdensity.circuits.ansatze.qcnn import qcnn, qcnn_layers, qcnn_readout_qubit
from qdensity.circuits.ansatze.registry import (
    FAMILIES,
    AnsatzFamily,
    estimator_ansatze,
    register_family,
)
from qdensity.circuits.ansatze.reuploading import chebyshev_dataset, reuploading

__all__ = [
    "pyramid",
    "x_circuit",
    "butterfly",
    "round_robin",
    "round_robin_pairs",
    "pairs_circuit",
    "hardware_efficient",
    "equivariant_commuting",
    "equivariant_noncommuting",
    "translation_classes",
    "angle_encoding",
    "equivariant_observable",
    "bars_and_dots",
    "qcnn",
    "qcnn_layers",
    "qcnn_readout_qubit",
    "reuploading",
    "chebyshev_dataset",
    "AnsatzFamily",
    "FAMILIES",
    "register_family",
    "estimator_ansatze",
]
