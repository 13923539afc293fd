"""Parameter rows of a density QNN's circuits (split from :mod:`qdensity.models.density`).

:func:`bind_rows` orders values by a circuit's parameters; :func:`_parameter_holder` gives a
small circuit whose ``parameters`` equal those of ``V(x)`` composed with ``U_k``, so
:meth:`~qdensity.models.DensityQNN.rows` orders its columns without copying ``U_k``
(``QuantumCircuit.parameters`` is sorted by name, whatever the gates).
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.validation import Circuit, Instance, validates

__all__ = ["bind_rows"]


@validates(circuit=Circuit(), columns=Instance(dict))
def bind_rows(circuit: QuantumCircuit, columns: dict) -> np.ndarray:
    """Parameter rows in ``circuit.parameters`` order from ``{Parameter: column}``.

    Parameters
    ----------
    circuit : QuantumCircuit
    columns : dict
        Maps each of the circuit's parameters to an array of shape (B,) or a scalar.

    Returns
    -------
    numpy.ndarray, shape (B, P)
    """
    params = list(circuit.parameters)
    missing = [p.name for p in params if p not in columns]
    if missing:
        raise ValueError(f"no values given for parameters {missing}")
    cols = [np.atleast_1d(np.asarray(columns[p], dtype=float)) for p in params]
    rows = max((c.size for c in cols), default=1)
    return np.stack([np.broadcast_to(c, (rows,)) for c in cols], axis=1) if cols else np.zeros(
        (rows, 0))


def _parameter_holder(encoding, sub: QuantumCircuit) -> QuantumCircuit:
    """A circuit with the parameters of ``encoding.circuit.compose(sub)`` (``sub`` itself when
    there is no encoding): one ``rz`` per parameter of either, so no copy of ``sub``."""
    if encoding is None:
        return sub
    holder = QuantumCircuit(1)
    for p in set(encoding.circuit.parameters) | set(sub.parameters):
        holder.rz(p, 0)
    return holder
