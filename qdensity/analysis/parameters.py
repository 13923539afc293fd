"""Trainable versus data parameters of a circuit.

Data enter a circuit through a ``ParameterVector`` named ``"x"`` (:data:`DATA_PREFIX`); every
other parameter is trainable. :func:`trainable_parameters` lives here, below the models and
gradients that use it, so that the block analysis (:mod:`qdensity.analysis.blocks`) can read it;
:mod:`qdensity.models.decompositions` re-exports it under the same name.
"""

from __future__ import annotations

from qiskit.circuit import QuantumCircuit

from qdensity.validation import Circuit, validates

__all__ = ["DATA_PREFIX", "trainable_parameters"]

DATA_PREFIX = "x"


@validates(circuit=Circuit())
def trainable_parameters(circuit: QuantumCircuit) -> list:
    """Parameters of ``circuit`` that are not data (not in a vector named ``"x"``), in order.

    Examples
    --------
    >>> from qiskit.circuit import ParameterVector, QuantumCircuit
    >>> x, theta = ParameterVector("x", 1), ParameterVector("theta", 2)
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.ry(x[0], 0); _ = qc.rz(theta[0], 0); _ = qc.ry(theta[1], 0)
    >>> [p.name for p in trainable_parameters(qc)]
    ['theta[0]', 'theta[1]']
    """
    return [p for p in circuit.parameters if not _is_data(p)]


def _is_data(param) -> bool:
    vector = getattr(param, "vector", None)
    return vector is not None and vector.name == DATA_PREFIX
