"""Exact evaluation and gradients of a density QNN on engines the model keeps (paper eq. 3).

A :class:`~qdensity.models.density.DensityQNN` keeps, for its lifetime, everything exact
evaluation needs, built on first use and never again:

* the composed circuits ``V(x) U_k`` (one per sub-unitary);
* an :class:`~qdensity.execution.AdjointEngine` with those circuits compiled once
  (every model family: RBS ansatze, hardware-efficient, equivariant, QCNN, re-uploading);
* the unary engine's compiled form of each sub-unitary (RBS/FBS models on unary inputs);
* an Aer :class:`~qdensity.execution.engines.ExactEngine` when asked for (``method="aer"``),
  which transpiles each template once.

:func:`exact_gradients` gives the per-sub-unitary outputs ``f_k``, their Jacobians w.r.t. the
trainable angles (Cor. 1 / Prop. 1) and w.r.t. the data-carrying angles (an encoding's
parameters, re-uploaded ``x[i]``), from one adjoint sweep per sub-unitary;
:mod:`qdensity.gradients.inputs` chains the latter to ``d f_k / d x``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.analysis.parameters import DATA_PREFIX
from qdensity.validation import MAX_DENSE_ENTRIES, Array, EngineLike, Instance, validates

__all__ = ["ModelEngines", "engines_of", "exact_outputs", "exact_gradients", "ExactGradients",
           "InputColumns", "input_columns", "uses_unary_engine", "unary_amplitudes",
           "z_readout_diagonal"]


@dataclass
class ModelEngines:
    """What a model keeps for exact evaluation (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> model = DensityQNN([reuploading(2)], seed=0)  # one qubit, <Z>, 6 angles
    >>> from qdensity.models.exact import engines_of
    >>> state = engines_of(model)
    >>> len(state.circuits), type(state.adjoint).__name__, state.unary is None
    (1, 'AdjointEngine', True)
    """

    circuits: list[QuantumCircuit]
    adjoint: object = None
    unary: list | None = None
    aer: object = None
    columns: dict = field(default_factory=dict)


def engines_of(model) -> ModelEngines:
    """The model's :class:`ModelEngines`, made on first use and kept in the model's
    :meth:`~qdensity.models.density.DensityQNN.derived` store (made again when its circuits,
    encoding, readout or observable change).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> model = DensityQNN([reuploading(2)], seed=0)  # one qubit, <Z>, 6 angles
    >>> from qdensity.models.exact import engines_of
    >>> engines_of(model) is engines_of(model)  # made once, kept
    True
    """
    known = model.derived("exact")
    state = known.get("engines")
    if state is None:
        from qdensity.execution.statevector.adjoint import AdjointEngine

        circuits = [model.circuit(k) for k in range(model.num_subunitaries)]
        state = known["engines"] = ModelEngines(circuits, AdjointEngine())
    return state


def unary_circuits(model) -> list:
    """The sub-unitaries compiled for the unary engine once per model (ValueError if not RBS)."""
    state = engines_of(model)
    if state.unary is None:
        from qdensity.execution.unary import compile_unary

        state.unary = [compile_unary(c) for c in model.sub_unitaries]
    return state.unary


def _readouts(model) -> list:
    """Adjoint observables of the readout: ``O``, or the outcome probabilities of ``e_j``."""
    n = model.num_qubits
    if model.readout == "observable":
        return [model.observable]
    if model.readout == "unary_amplitudes":
        raise ValueError("unary_amplitudes need the unary engine (signs are not in the "
                         "probabilities); use method='unary'")
    out = []
    for j in range(n):
        d = np.zeros(2**n)
        d[1 << j] = 1.0
        out.append(d)
    return out


@dataclass(frozen=True)
class InputColumns:
    """Where the data enter one circuit ``V(x) U_k``.

    Attributes
    ----------
    encoding : numpy.ndarray of int, shape (P_enc,)
        The circuit columns of the encoding's parameters, in ``encoding.circuit.parameters``
        order (empty without an encoding).
    data : numpy.ndarray of int, shape (D,)
        The circuit columns of re-uploaded data parameters ``x[i]``.
    features : numpy.ndarray of int, shape (D,)
        The feature ``i`` each of those columns reads.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.models.exact import InputColumns
    >>> InputColumns(np.array([1, 2]), np.array([0]), np.array([0])).columns.tolist()
    [1, 2, 0]
    """

    encoding: np.ndarray
    data: np.ndarray
    features: np.ndarray

    @property
    def columns(self) -> np.ndarray:
        """Every data-carrying column: encoding first, then re-uploaded."""
        return np.concatenate([self.encoding, self.data]).astype(int)


def input_columns(model, circuit: QuantumCircuit) -> InputColumns:
    """The columns of ``circuit`` (built on ``model.circuit(k)``) that carry data: the
    encoding's parameters (set from ``encoding.values(X)``, which take precedence) and the
    re-uploaded features ``x[i]``.

    Examples
    --------
    A re-uploading circuit reads feature 0 in its column 0 (``x[0]`` sorts first):

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> model = DensityQNN([reuploading(2)], seed=0)  # one qubit, <Z>, 6 angles
    >>> from qdensity.models.exact import input_columns
    >>> cols = input_columns(model, model.circuit(0))
    >>> cols.encoding.tolist(), cols.data.tolist(), cols.features.tolist()
    ([], [0], [0])
    """
    index = {p: i for i, p in enumerate(circuit.parameters)}
    enc = model.encoding
    enc_params = list(enc.circuit.parameters) if enc is not None else []
    enc_cols = [index[p] for p in enc_params if p in index]
    taken = set(enc_params)
    data, features = [], []
    for i, p in enumerate(circuit.parameters):
        if p not in taken and getattr(getattr(p, "vector", None), "name", None) == DATA_PREFIX:
            data.append(i)
            features.append(p.index)
    as_int = lambda v: np.asarray(v, dtype=int)  # noqa: E731
    return InputColumns(as_int(enc_cols), as_int(data), as_int(features))


def _columns(model, k: int):
    """Column indices of circuit k: trainable (in sub-unitary order), and the data columns."""
    state = engines_of(model)
    if k not in state.columns:
        circ = state.circuits[k]
        index = {p: i for i, p in enumerate(circ.parameters)}
        from qdensity.models.decompositions import trainable_parameters

        trainable = np.array([index[p] for p in trainable_parameters(model.sub_unitaries[k])],
                             dtype=int)
        state.columns[k] = (trainable, input_columns(model, circ))
    return state.columns[k]


@validates(
    model=Instance('qdensity.models.density:DensityQNN'),
    X=[Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), None], theta=[Array(ndim=(1, 2)), None],
    engine=[EngineLike(), None],
)
def exact_outputs(model, X=None, theta=None, engine=None) -> np.ndarray:
    """Exact ``f_k(x)`` on the adjoint engine: (B, K) for an observable, (B, K, n) for unary
    probabilities.

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d), optional
    theta : array_like, shape (P,), optional
    engine : AdjointEngine, optional
        Default: the model's own.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    Each sub-unitary's unary probabilities sum to 1; mixed by ``alpha`` they are the model's
    prediction:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models import DensityQNN, Encoding
    >>> from qdensity.models.decompositions import by_moments
    >>> model = DensityQNN(by_moments(round_robin(3)).sub_unitaries, encoding=Encoding.unary(3),
    ...                    readout="unary_probabilities", seed=0)
    >>> from qdensity.models.exact import exact_outputs
    >>> X = np.array([[1.0, 2.0, 3.0]])
    >>> f = exact_outputs(model, X)
    >>> f.shape, bool(np.allclose(f.sum(axis=2), 1.0))
    ((1, 3, 3), True)
    >>> bool(np.allclose(np.einsum("bk,bkn->bn", model.alpha(X) * np.ones((1, 3)), f),
    ...                  model.predict(X)))
    True
    """
    state = engines_of(model)
    engine = engine or state.adjoint
    obs = _readouts(model)
    outs = [engine.expectation(c, obs, model.rows(k, X, theta, circuit=c))
            for k, c in enumerate(state.circuits)]
    out = np.stack(outs, axis=1)
    return out[:, :, 0] if model.readout == "observable" else out


def aer_outputs(model, X=None, theta=None) -> np.ndarray:
    """The same as :func:`exact_outputs` from Aer statevectors (an ExactEngine kept on the
    model, each template transpiled once)."""
    from qdensity.execution.exact import ExactEngine
    from qdensity.execution.plans import probabilities_plan

    state = engines_of(model)
    if state.aer is None:
        state.aer = ExactEngine()
    outs = []
    for k, circ in enumerate(state.circuits):
        if model.readout == "observable":
            outs.append(model.expectation_plan(k, X, theta).run(state.aer).value)
        else:
            _readouts(model)
            res = probabilities_plan(circ, model.rows(k, X, theta, circuit=circ)).run(state.aer)
            outs.append(res.probabilities[:, 1 << np.arange(model.num_qubits)])
    return np.stack(outs, axis=1)


@validates(
    outputs=Array(ndim=None, min_size=0), jacobians=Instance(list), data_columns=Instance(list),
    data_jacobians=[Instance(list), None],
)
@dataclass
class ExactGradients:
    """Exact outputs and Jacobians of every sub-unitary for one batch.

    Attributes
    ----------
    outputs : numpy.ndarray, shape (B, K, m)
    jacobians : list of numpy.ndarray, each (B, m, P_k)
        ``d f_k / d theta_k`` in sub-unitary k's parameter order.
    data_columns : list of InputColumns
        Where the data enter each circuit.
    data_jacobians : list of numpy.ndarray (B, m, len(data_columns[k].columns)), or None
        ``d f_k`` w.r.t. those columns (None when asked for no input gradients);
        :func:`qdensity.gradients.inputs.input_jacobians` chains them to ``d f_k / d x``.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> model = DensityQNN([reuploading(2)], seed=0)  # one qubit, <Z>, 6 angles
    >>> from qdensity.models.exact import exact_gradients
    >>> g = exact_gradients(model, np.array([[0.3], [0.8]]), inputs=False)
    >>> g.outputs.shape, [j.shape for j in g.jacobians], g.data_jacobians
    ((2, 1, 1), [(2, 1, 6)], None)
    """

    outputs: np.ndarray
    jacobians: list[np.ndarray]
    data_columns: list[InputColumns]
    data_jacobians: list[np.ndarray] | None = None


@validates(
    model=Instance('qdensity.models.density:DensityQNN'),
    X=[Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), None], engine=[EngineLike(), None],
    inputs=Instance(bool),
)
def exact_gradients(model, X=None, engine=None, inputs: bool = True) -> ExactGradients:
    """Outputs and Jacobians of every sub-unitary by adjoint differentiation.

    One forward and one backward statevector sweep per data row and sub-unitary
    (``O(gates x 2^n)``), for the trainable angles and the data-carrying angles at once.

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d), optional
    engine : AdjointEngine, optional
        Default: the model's own (kept for the model's lifetime).
    inputs : bool
        Also differentiate w.r.t. the data-carrying columns (for input gradients).

    Returns
    -------
    ExactGradients

    Examples
    --------
    Against central finite differences of :func:`exact_outputs` in every angle:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> model = DensityQNN([reuploading(2)], seed=0)  # one qubit, <Z>, 6 angles
    >>> from qdensity.models.exact import exact_gradients, exact_outputs
    >>> X, th = np.array([[0.3], [0.8]]), model.theta
    >>> fd = np.stack([(exact_outputs(model, X, th + e) - exact_outputs(model, X, th - e))[:, 0]
    ...                / 2e-6 for e in 1e-6 * np.eye(6)], axis=-1)
    >>> bool(np.allclose(exact_gradients(model, X).jacobians[0][:, 0], fd, atol=1e-6))
    True
    """
    state = engines_of(model)
    engine = engine or state.adjoint
    obs = _readouts(model)
    outs, jacs, data_jacs, columns = [], [], [], []
    inputs = inputs and X is not None
    for k, circ in enumerate(state.circuits):
        trainable, data = _columns(model, k)
        wrt = np.concatenate([trainable, data.columns if inputs else []]).astype(int)
        vals, jac = engine.value_and_gradient(circ, obs, model.rows(k, X, circuit=circ), wrt)
        outs.append(vals)
        jacs.append(jac[:, :, :trainable.size])
        data_jacs.append(jac[:, :, trainable.size:])
        columns.append(data)
    return ExactGradients(np.stack(outs, axis=1), jacs, columns, data_jacs if inputs else None)


def uses_unary_engine(model) -> bool:
    """True when ``model`` runs on the unary engine: RBS/FBS sub-unitaries on a unary encoding
    and, for an observable readout, a diagonal (I/Z) observable. Kept in the model's derived
    store, so it is recomputed when the circuits, encoding, readout or observable change.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models import DensityQNN, Encoding
    >>> from qdensity.models.decompositions import by_moments
    >>> model = DensityQNN(by_moments(round_robin(3)).sub_unitaries, encoding=Encoding.unary(3),
    ...                    readout="unary_probabilities", seed=0)
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models.exact import uses_unary_engine
    >>> uses_unary_engine(model), uses_unary_engine(DensityQNN([reuploading(2)]))
    (True, False)
    """
    known = model.derived("unary")
    if "ok" not in known:
        ok = model.encoding is not None and model.encoding.kind == "unary"
        if ok:
            try:
                unary_circuits(model)  # compiled once, kept on the model
            except ValueError:
                ok = False
        if ok and model.readout == "observable":
            ok = not np.any(model.observable.paulis.x)
        known["ok"] = ok
    return known["ok"]


def unary_amplitudes(model, X, theta) -> np.ndarray:
    """Unary amplitudes ``y_k(x)`` of every sub-unitary, shape (B, K, n) (inputs normalised).

    Examples
    --------
    The squared amplitudes are the unary probabilities (their signs are in no measurement):

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models import DensityQNN, Encoding
    >>> from qdensity.models.decompositions import by_moments
    >>> model = DensityQNN(by_moments(round_robin(3)).sub_unitaries, encoding=Encoding.unary(3),
    ...                    readout="unary_probabilities", seed=0)
    >>> from qdensity.models.exact import exact_outputs, unary_amplitudes
    >>> X = np.array([[1.0, -2.0, 3.0]])
    >>> y = unary_amplitudes(model, X, model.theta)
    >>> y.shape, bool(np.allclose(y**2, exact_outputs(model, X)))
    ((1, 3, 3), True)
    """
    from qdensity.execution.unary import forward

    X = model._check_X(X)
    norms = np.linalg.norm(X, axis=1, keepdims=True)
    if np.any(norms == 0):
        raise ValueError("X has an all-zero row; a unary encoding cannot load it")
    Xn = X / norms
    return np.stack([forward(c, Xn, model._sub_theta(k, theta))
                     for k, c in enumerate(unary_circuits(model))], axis=1)


def z_readout_diagonal(observable) -> np.ndarray:
    """``<e_j| O |e_j>`` for a diagonal observable: f_k = sum_j y_j^2 * this[j], shape (n,).

    ``sum_t c_t s_t (1 - 2 z_t[j])`` for Z-type terms ``s_t Z^{z_t}`` (``s_t`` the Pauli's
    phase): ``e_j`` has its one 1 on qubit j. O(terms x n), no 2^n table.

    Examples
    --------
    ``Z_0 + Z_2 / 2`` on ``e_0, e_1, e_2``: ``-1 + 1/2``, ``1 + 1/2``, ``1 - 1/2``:

    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.models.exact import z_readout_diagonal
    >>> z_readout_diagonal(SparsePauliOp(["IIZ", "ZII"], [1.0, 0.5])).tolist()
    [-0.5, 1.5, 0.5]
    """
    paulis = observable.paulis
    if np.any(paulis.x):
        raise ValueError("the unary readout needs a diagonal (I/Z) observable")
    coeff = np.real(np.asarray(observable.coeffs) * (-1j) ** paulis.phase)
    return coeff @ (1.0 - 2.0 * paulis.z)
