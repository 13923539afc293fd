"""Gradients w.r.t. the input features ``x``, for every encoding and re-uploading circuit.

Data reach a density QNN's circuit ``V(x) U_k`` (paper eq. 1) as circuit parameters in two
ways: through an encoding's parameters ``phi = T(x)`` (``T`` the encoding's ``transform``) and
as re-uploaded features ``x[i]`` bound directly to the data parameters of ``U_k``. So

    d f / d x_i = sum_p (d f / d phi_p) (d phi_p / d x_i) + sum_{c: feature(c) = i} d f / d c

where the circuit derivatives come from the adjoint engine (exact, :func:`input_jacobians`)
or from shift rules on the data parameters (:func:`input_gradient_plan`, exact or sampled), and
``d phi / d x`` is the encoding's Jacobian (:func:`encoding_jacobian`): the identity for the
angle encoding, the analytic derivative of the loader angles for the unary encoding
(``phi = arctan2(a(T), a(S))`` per RBS, ``a`` a signed entry or a sub-norm), and the
``jacobian`` a user gives with their own :class:`~qdensity.models.encoding.Encoding`.

The model's output ``f(x) = sum_k alpha_k(x) f_k(x)`` (eq. 3) then has

    dL/dx = sum_k alpha_k(x) (dL/df . d f_k / d x) + sum_k (dL/df . f_k) d alpha_k / d x

(:func:`input_vjp`), the second sum nonzero for a data-dependent mixture (the
mixture-of-experts gate, Supp. H), whose ``d alpha / d x`` is classical. Observable readouts
and unary probabilities (the four-term RBS rule on the loader's angles, chained with
:func:`loader_angles_jacobian`) are both sampled by :func:`input_gradient_plan`; unary
amplitudes carry signs that no measurement gives and are differentiated exactly only.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from qdensity.execution.plans import Estimate, Plan
from qdensity.models.exact import ExactGradients, InputColumns

__all__ = ["encoding_jacobian", "loader_angles_jacobian", "input_jacobian", "input_jacobians",
           "input_gradient_plan", "input_vjp"]


def loader_angles_jacobian(X, layout: str = "parallel") -> np.ndarray:
    """``d phi / d x`` of :func:`~qdensity.circuits.loaders.loader_angles`, exact.

    Each RBS angle is ``phi = arctan2(t, s)`` with ``t``, ``s`` the signed entry of a
    one-element range or the norm of a longer one, so
    ``d phi = (s dt - t ds) / (s^2 + t^2)``, ``d ||v|| = v / ||v||`` (0 where ``v = 0``,
    the subgradient the loader's angle takes there).

    Parameters
    ----------
    X : array_like, shape (B, d)
        No zero rows.
    layout : {"parallel", "diagonal", "semi_diagonal"}

    Returns
    -------
    numpy.ndarray, shape (B, d - 1, d)

    Examples
    --------
    The angles do not change when ``x`` is scaled, so ``J x = 0``; and ``J`` matches central
    finite differences:

    >>> import numpy as np
    >>> from qdensity.circuits.loaders import loader_angles
    >>> from qdensity.gradients.inputs import loader_angles_jacobian
    >>> x = np.array([[1.0, 2.0, 3.0, 4.0]])
    >>> J = loader_angles_jacobian(x)
    >>> fd = [(loader_angles(x + 1e-6 * e) - loader_angles(x - 1e-6 * e))[0] / 2e-6
    ...       for e in np.eye(4)]
    >>> J.shape, bool(np.allclose(J[0] @ x[0], 0)), bool(np.allclose(J[0].T, fd, atol=1e-6))
    ((1, 3, 4), True, True)
    """
    from qdensity.circuits.loaders import _plan, loader_angles

    X = np.atleast_2d(np.asarray(X, dtype=float))
    loader_angles(X, layout)  # the same checks (finite, d >= 2, no zero rows)
    B, d = X.shape
    plan = _plan(d, layout)
    out = np.zeros((B, len(plan.nodes), d))

    def amplitude(lo, hi):
        grad = np.zeros((B, d))
        if hi - lo == 1:
            grad[:, lo] = 1.0
            return X[:, lo], grad
        v = X[:, lo:hi]
        norm = np.linalg.norm(v, axis=1)
        grad[:, lo:hi] = v / np.where(norm > 0, norm, 1.0)[:, None]
        return norm, grad

    for k, node in enumerate(plan.nodes):
        t, dt = amplitude(*node.tgt_range)
        s, ds = amplitude(*node.src_range)
        r2 = s**2 + t**2
        r2 = np.where(r2 > 0, r2, 1.0)
        out[:, k, :] = (s[:, None] * dt - t[:, None] * ds) / r2[:, None]
    return out


def encoding_jacobian(encoding, X) -> np.ndarray:
    """``d phi / d x`` of an encoding's parameters w.r.t. the features.

    Parameters
    ----------
    encoding : Encoding
        ``kind`` ``"angle"`` (identity), ``"unary"`` (:func:`loader_angles_jacobian`) or any
        encoding with a ``jacobian`` callable ``X (B, d) -> (B, P_enc, d)``.
    X : array_like, shape (B, d)

    Returns
    -------
    numpy.ndarray, shape (B, P_enc, d)

    Raises
    ------
    ValueError
        For an encoding of another kind without a ``jacobian``.

    Examples
    --------
    The angle encoding's parameters are the features themselves (its gates scale them):

    >>> from qdensity.gradients.inputs import encoding_jacobian
    >>> from qdensity.models.encoding import Encoding
    >>> encoding_jacobian(Encoding.angle(2), [[0.1, 0.2], [0.3, 0.4]]).tolist()
    [[[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]]]
    >>> encoding_jacobian(Encoding.unary(4), [[1.0, 2.0, 3.0, 4.0]]).shape  # 3 loader angles
    (1, 3, 4)
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    jac = getattr(encoding, "jacobian", None)
    if jac is not None:
        out = np.asarray(jac(X), dtype=float)
        want = (X.shape[0], encoding.circuit.num_parameters, X.shape[1])
        if out.shape != want:
            raise ValueError(f"encoding.jacobian(X) must have shape {want} (B, P_enc, d), got "
                             f"{out.shape}")
        return out
    if encoding.kind == "angle":
        P = encoding.circuit.num_parameters
        return np.broadcast_to(np.eye(P, X.shape[1]), (X.shape[0], P, X.shape[1])).copy()
    if encoding.kind == "unary":
        layout = getattr(encoding.transform, "keywords", {}).get("layout", "parallel")
        return loader_angles_jacobian(X, layout)
    raise ValueError(f"input gradients through an encoding of kind {encoding.kind!r} need its "
                     "jacobian: give Encoding(..., jacobian=f) with f(X) of shape "
                     "(B, P_enc, d), d phi / d x")


def input_jacobian(model, X, columns: InputColumns, jac: np.ndarray) -> np.ndarray:
    """``d f / d x`` from the circuit Jacobian w.r.t. the data-carrying columns.

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d)
    columns : InputColumns
    jac : numpy.ndarray, shape (B, M, len(columns.columns))
        ``d f_m / d value`` of those columns, encoding columns first.

    Returns
    -------
    numpy.ndarray, shape (B, M, d)

    Examples
    --------
    A re-uploading model (the feature enters as a circuit parameter), against finite
    differences of its exact outputs:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> from qdensity.models.exact import exact_gradients, exact_outputs
    >>> model, X = DensityQNN([reuploading(2)], seed=0), np.array([[0.3], [0.8]])
    >>> from qdensity.gradients.inputs import input_jacobian
    >>> g = exact_gradients(model, X)
    >>> jac = input_jacobian(model, X, g.data_columns[0], g.data_jacobians[0])  # k = 0
    >>> fd = (exact_outputs(model, X + 1e-6) - exact_outputs(model, X - 1e-6)) / 2e-6
    >>> jac.shape, bool(np.allclose(jac[:, 0, 0], fd[:, 0], atol=1e-6))
    ((2, 1, 1), True)
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    B, M = jac.shape[:2]
    out = np.zeros((B, M, X.shape[1]))
    ne = columns.encoding.size
    if ne:
        out += np.einsum("bmp,bpd->bmd", jac[:, :, :ne], encoding_jacobian(model.encoding, X))
    for c, feature in enumerate(columns.features):
        out[:, :, feature] += jac[:, :, ne + c]
    return out


def input_jacobians(model, X, gradients: ExactGradients) -> list[np.ndarray]:
    """``d f_k / d x`` of every sub-unitary, shape (B, m, d) each, from
    :func:`~qdensity.models.exact.exact_gradients` (one adjoint sweep gave the data columns'
    derivatives with the trainable ones).

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d)
    gradients : ExactGradients
        Of the same ``X``.

    Returns
    -------
    list of numpy.ndarray, K arrays of shape (B, m, d)

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> from qdensity.models.exact import exact_gradients, exact_outputs
    >>> model, X = DensityQNN([reuploading(2)], seed=0), np.array([[0.3], [0.8]])
    >>> from qdensity.gradients.inputs import input_jacobians
    >>> jacs = input_jacobians(model, X, exact_gradients(model, X))
    >>> fd = (exact_outputs(model, X + 1e-6) - exact_outputs(model, X - 1e-6)) / 2e-6
    >>> len(jacs), bool(np.allclose(jacs[0][:, 0, 0], fd[:, 0], atol=1e-6))
    (1, True)
    """
    if gradients.data_jacobians is None:
        raise ValueError("gradients has no data Jacobians (exact_gradients(..., inputs=False)); "
                         "compute them with inputs=True")
    return [input_jacobian(model, X, cols, jac) for cols, jac in
            zip(gradients.data_columns, gradients.data_jacobians, strict=True)]


def input_gradient_plan(model, X, *, shots: int | None = None) -> Plan:
    """Plan for ``d f_k / d x`` of every sub-unitary by shift rules on the data parameters.

    The circuit ``V(x) U_k`` is differentiated w.r.t. every data-carrying parameter (the
    encoding's and the re-uploaded ``x[i]``) with the rules of
    :func:`~qdensity.gradients.shift.parameter_shift_plan` (two terms for Pauli rotations,
    four for RBS, Supp. E eq. 23: the unary loader's angles take the four-term rule, as later
    gates touch their qubits), then chained to the features as in :func:`input_jacobian`
    (through :func:`loader_angles_jacobian` for the unary encoding). Runs on any engine:
    exact, or sampled with ``shots`` per circuit.

    Parameters
    ----------
    model : DensityQNN
        With ``readout="observable"`` or ``"unary_probabilities"`` (the unary outcome
        frequencies, read off the measured bits).
    X : array_like, shape (B, d)
    shots : int, optional
        Shots per shifted circuit; exact when None.

    Returns
    -------
    Plan
        Post-processing returns a list of K :class:`~qdensity.execution.plans.Estimate` of shape
        (B, m, d), ``m = 1`` for an observable and ``n`` for unary probabilities (standard
        errors propagated through the chain rule, shifted circuits being independent).
        ``plan.meta["input_circuits"]`` is the number of circuits per data point, summed over
        the sub-unitaries, ``plan.meta["input_circuits_per_subunitary"]`` the K terms of that
        sum; sampled, the plan spends ``B * meta["input_circuits"] * shots`` shots.

    Raises
    ------
    ValueError
        For ``readout="unary_amplitudes"`` (their signs are in no measured distribution).

    Examples
    --------
    Run exactly, the shift rules give the adjoint engine's input Jacobians:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> from qdensity.models.exact import exact_gradients, exact_outputs
    >>> model, X = DensityQNN([reuploading(2)], seed=0), np.array([[0.3], [0.8]])
    >>> from qdensity.execution.engines import ExactEngine
    >>> from qdensity.gradients.inputs import input_gradient_plan, input_jacobians
    >>> est = input_gradient_plan(model, X).run(ExactEngine())[0]  # sub-unitary 0
    >>> exact = input_jacobians(model, X, exact_gradients(model, X))[0]
    >>> est.value.shape, bool(np.allclose(est.value, exact))
    ((2, 1, 1), True)
    >>> input_gradient_plan(model, X, shots=100).total_shots  # 2 rows x 4 circuits x 100
    800
    """
    from qdensity.gradients.shift import parameter_shift_plan
    from qdensity.models.exact import input_columns

    if model.readout not in ("observable", "unary_probabilities"):
        raise ValueError(f"input_gradient_plan needs readout='observable' or "
                         f"'unary_probabilities', got {model.readout!r} (amplitude signs are "
                         "not measured); use the exact engines (QuantumLayer or the torch "
                         "layer with engine='exact') for unary amplitudes")
    X = np.atleast_2d(np.asarray(X, dtype=float))
    B = max(X.shape[0], 1)
    unary = model.readout == "unary_probabilities"
    plans, columns = [], []
    for k in range(model.num_subunitaries):
        circ = model.circuit(k)
        cols = input_columns(model, circ)
        params = [circ.parameters[c] for c in cols.columns]
        plans.append(parameter_shift_plan(circ, None if unary else model.observable,
                                          model.rows(k, X, circuit=circ), parameters=params,
                                          shots=shots, label=f"input_gradient_k{k}",
                                          unary=unary))
        columns.append(cols)
    combined = Plan.combine(plans, "input gradient")
    per_k = [p.num_circuits // B for p in plans]
    post = partial(_input_post, combined, model, X, columns)
    return Plan(combined.jobs, post, "input gradient",
                {"input_circuits": sum(per_k), "input_circuits_per_subunitary": per_k})


def input_vjp(model, X, outputs: np.ndarray, jacobians, upstream: np.ndarray) -> np.ndarray:
    """``d L / d x`` of the model's output ``f(x) = sum_k alpha_k(x) f_k(x)`` (eq. 3).

    ``sum_k alpha_k (dL/df . d f_k / d x) + mixture.input_vjp(x, dL/df . f_k)``: the second
    term, ``d alpha / d x`` times the sub-unitaries' outputs, is nonzero only for a
    data-dependent mixture (the gate of Supp. H, eq. 26).

    Parameters
    ----------
    model : DensityQNN
    X : array_like, shape (B, d)
    outputs : numpy.ndarray, shape (B, K, m)
        ``f_k(x)``, exact or estimated.
    jacobians : sequence of K numpy.ndarray, shape (B, m, d)
        ``d f_k / d x`` (:func:`input_jacobians`, or the values of
        :func:`input_gradient_plan`).
    upstream : numpy.ndarray, shape (B, m)
        ``d L / d f``.

    Returns
    -------
    numpy.ndarray, shape (B, d)

    Examples
    --------
    With ``L = sum_b u_b f(x_b)``, ``dL/dx_b = u_b f'(x_b)``:

    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import reuploading
    >>> from qdensity.models import DensityQNN
    >>> from qdensity.models.exact import exact_gradients, exact_outputs
    >>> model, X = DensityQNN([reuploading(2)], seed=0), np.array([[0.3], [0.8]])
    >>> from qdensity.gradients.inputs import input_jacobians, input_vjp
    >>> g, u = exact_gradients(model, X), np.array([[1.0], [-2.0]])
    >>> grad = input_vjp(model, X, g.outputs, input_jacobians(model, X, g), u)
    >>> fd = (model.predict(X + 1e-6) - model.predict(X - 1e-6)) / 2e-6
    >>> grad.shape, bool(np.allclose(grad[:, 0], u[:, 0] * fd, atol=1e-6))
    ((2, 1), True)
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    upstream = np.atleast_2d(np.asarray(upstream, dtype=float))
    outputs = np.asarray(outputs, dtype=float)
    alpha = np.broadcast_to(model.alpha(X), outputs.shape[:2])
    out = np.zeros(X.shape)
    for k, jac in enumerate(jacobians):
        out += np.einsum("bm,bmd->bd", upstream * alpha[:, k:k + 1], jac)
    if model.mixture.data_dependent:
        out += model.mixture.input_vjp(X, np.einsum("bm,bkm->bk", upstream, outputs))
    return out


def _input_post(combined, model, X, columns, results) -> list[Estimate]:
    out = []
    for est, cols in zip(combined.postprocess(results), columns, strict=True):
        value, err = np.asarray(est.value), np.asarray(est.standard_error)
        if value.ndim == 2:  # an observable: one output
            value, err = value[:, None, :], err[:, None, :]
        var = _squared_chain(model, X, cols, err ** 2)
        out.append(Estimate(input_jacobian(model, X, cols, value), np.sqrt(var)))
    return out


def _squared_chain(model, X, cols: InputColumns, var: np.ndarray) -> np.ndarray:
    """Variances through the chain rule: ``sum_c (d c / d x_i)^2 var_c``."""
    out = np.zeros(var.shape[:2] + (X.shape[1],))
    ne = cols.encoding.size
    if ne:
        out += np.einsum("bmp,bpd->bmd", var[:, :, :ne],
                         encoding_jacobian(model.encoding, X) ** 2)
    for c, feature in enumerate(cols.features):
        out[:, :, feature] += var[:, :, ne + c]
    return out
