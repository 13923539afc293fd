"""Parameter rows of a density QNN's circuits (split from :mod:`qdensity.models.density`).

:func:`bind_rows` orders values by a circuit's parameters; :func:`_parameter_holder` gives a
small circuit whose ``parameters`` equal those of ``V(x)`` composed with ``U_k``, so
:meth:`~qdensity.models.DensityQNN.rows` orders its columns without copying ``U_k``
(``QuantumCircuit.parameters`` is sorted by name, whatever the gates).
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.models.decompositions import DATA_PREFIX
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

    Examples
    --------
    ``circuit.parameters`` is sorted by name (``a`` before ``b``); a scalar is broadcast down
    the rows:

    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.circuit import Parameter
    >>> from qdensity.models import bind_rows
    >>> a, b = Parameter("a"), Parameter("b")
    >>> qc = QuantumCircuit(1); _ = qc.rx(b, 0); _ = qc.ry(a, 0)
    >>> bind_rows(qc, {b: np.array([1.0, 2.0, 3.0]), a: 0.5}).tolist()
    [[0.5, 1.0], [0.5, 2.0], [0.5, 3.0]]
    """
    return _placed(list(circuit.parameters), columns)


def _placed(params: list, columns: dict) -> np.ndarray:
    """:func:`bind_rows` on the circuit's parameters ``params`` (in order)."""
    missing = [p.name for p in params if p not in columns]
    if missing:
        raise ValueError(f"no values given for parameters {missing}")
    cols = [columns[p] for p in params]
    rows = max((c.size if type(c) is np.ndarray else np.size(c) for c in cols), default=1)
    out = np.empty((rows, len(params)))
    # full float columns and float scalars (data and angles) placed by two assignments, the
    # others one by one
    full: list[np.ndarray] = []
    scalars: list = []
    full_at: list[int] = []
    scalar_at: list[int] = []
    rest: list[int] = []
    for i, c in enumerate(cols):
        if type(c) is np.ndarray and c.dtype.kind == "f" and c.ndim < 2:
            if c.ndim == 0:  # an angle read off theta: theta[..., i] of a vector
                scalars.append(c)
                scalar_at.append(i)
            elif c.size == rows:
                full.append(c)
                full_at.append(i)
            else:
                rest.append(i)
        elif isinstance(c, (float, np.floating)):
            scalars.append(c)
            scalar_at.append(i)
        else:
            rest.append(i)
    if full:
        out[:, full_at] = np.stack(full, axis=1)
    if scalars:
        out[:, scalar_at] = np.array(scalars, dtype=float)
    for i in rest:  # a scalar or a (1,) column is broadcast down the rows
        c = cols[i]
        c = np.asarray(c, dtype=float)
        if c.ndim > 1 or c.size not in (1, rows):
            raise ValueError(f"the values of {params[i].name} have shape {c.shape}; expected "
                             f"a scalar or shape ({rows},)")
        out[:, i] = c
    return out


def _parameter_holder(encoding, sub: QuantumCircuit) -> QuantumCircuit:
    """A circuit with the parameters of ``encoding.circuit.compose(sub)`` (``sub`` itself when
    there is no encoding): one ``rz`` per parameter of either, so no copy of ``sub``."""
    if encoding is None:
        return sub
    holder = QuantumCircuit(1)
    for p in set(encoding.circuit.parameters) | set(sub.parameters):
        holder.rz(p, 0)
    return holder


def encoding_columns(model, X) -> dict:
    """``{encoding parameter: its column of values for X}`` (empty without X or encoding):
    what every sub-unitary's rows share, computed once for all of them."""
    if X is None or model.encoding is None:
        return {}
    enc = model.encoding.values(model._check_X(X))
    return dict(zip(model.encoding.circuit.parameters, enc.T, strict=True))


def model_rows(model, k: int, X, theta, circuit: QuantumCircuit | None,
               encoded: dict | None = None) -> np.ndarray:
    """:meth:`DensityQNN.rows <qdensity.models.density.DensityQNN.rows>`: the parameter rows of
    ``model.circuit(k)`` (or of ``circuit`` built on it) for data X, shape (B, P_circuit).
    ``encoded``: :func:`encoding_columns` of ``(model, X)`` when already computed."""
    circ = (circuit if circuit is not None  # parameters only: no copy of U_k
            else _parameter_holder(model.encoding, model.sub_unitaries[k]))
    theta = model.theta if theta is None else model._check_theta(theta)
    cols: dict = {}
    B = 1
    if X is not None:
        X = model._check_X(X)
        B = X.shape[0]
        cols.update(encoding_columns(model, X) if encoded is None else encoded)
    params = list(circ.parameters)  # sorted by name once, for the columns and the rows
    for p in params:
        if p in cols:
            continue
        vec = getattr(p, "vector", None)
        if vec is not None and vec.name == DATA_PREFIX:
            if X is None:
                raise ValueError("this model uploads data; X is required")
            cols[p] = X[:, p.index]
        elif p in model._index:
            cols[p] = theta[..., model._index[p]]
    out = _placed(params, cols)
    if out.shape[0] == 1 and B > 1:
        out = np.repeat(out, B, axis=0)
    return out
