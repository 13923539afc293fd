"""Mitigated, post-selected expectation values of diagonal observables (one sampled job).

The corrections themselves live with the device (:mod:`qdensity.hardware.mitigation`: mthree's
readout mitigation and Hamming-weight post-selection); this module runs the job through a
:class:`~qdensity.execution.engines.SamplerEngine` and composes them. With ``q`` the corrected
quasi-distribution (mthree's), ``S`` the kept outcomes and ``kappa = sum_S q`` the kept
fraction, the value is ``V = sum_S q(b) h(b) / kappa``.

Its standard error is the delta method on ``V`` as a function of everything that was sampled
(:func:`mitigated_expectation` gives the formulas): the ``N`` shots of the row (a multinomial
frequency vector ``p``) and the calibration (each qubit's two readout error rates, binomial
frequencies over the calibration shots that prepared it in ``|0>`` and in ``|1>``), with
``q = A^-1 p`` for the tensor product ``A`` of the calibrated single-qubit readout matrices.
mthree's overhead heuristic ``M Var_q(h) / (kappa N)`` misses both on near-basis states (there
``Var_q(h)`` is near 0 although the flipped shots and the calibration still scatter ``V``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.execution.plans import CircuitJob, check_observable, diagonal_values, measured
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.mitigation import ReadoutMitigator, _measured_qubits, hamming_weights
from qdensity.validation import as_parameter_rows, check_circuit, check_positive_int

__all__ = ["MitigatedEstimate", "mitigated_expectation"]


@dataclass
class MitigatedEstimate:
    """An estimate after readout mitigation and post-selection.

    Attributes
    ----------
    value : numpy.ndarray, shape (rows,)
        Mitigated, post-selected value.
    standard_error : numpy.ndarray, shape (rows,)
        Delta-method standard error over the row's shots and the calibration's shots (see
        :func:`mitigated_expectation`).
    kept_fraction : numpy.ndarray, shape (rows,)
        ``kappa``: weight of the kept outcomes (1 without post-selection).
    overhead : numpy.ndarray, shape (rows,)
        ``M``: mitigation overhead (1 without mitigation).
    shots : int
        Shots per row ``N``.
    """

    value: np.ndarray
    standard_error: np.ndarray
    kept_fraction: np.ndarray
    overhead: np.ndarray
    shots: int

    def __iter__(self):
        return iter((self.value, self.standard_error))



def mitigated_expectation(
    circuit: QuantumCircuit,
    observable: SparsePauliOp,
    values,
    *,
    engine: SamplerEngine,
    shots: int,
    mitigator: ReadoutMitigator | None = None,
    postselect: int | None = 1,
    label: str = "mitigated",
) -> MitigatedEstimate:
    """``<psi(values)| H |psi(values)>`` for a diagonal ``H``, mitigated and post-selected.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured state preparation with ``P`` free parameters (for a density QNN, one
        sub-unitary's circuit with its encoding: ``model.circuit(k)``, rows ``model.rows(k, X)``).
    observable : SparsePauliOp
        Z-type (diagonal) observable on ``circuit.num_qubits`` qubits.
    values : array_like, shape (rows, P) or (P,)
    engine : SamplerEngine
        Samples the circuit (one job, ``rows`` rows); its ledger records the shots.
    shots : int
        Shots per row.
    mitigator : ReadoutMitigator, optional
        Readout-error mitigation; None: raw counts.
    postselect : int or None
        Keep only outcomes of this Hamming weight (1 for unary models); None keeps all.
    label : str
        Ledger label of the job.

    Returns
    -------
    MitigatedEstimate

    Raises
    ------
    ValueError
        A non-diagonal observable, a row that keeps no outcome, or a bad weight.

    Notes
    -----
    Standard error (delta method, evaluated at the estimates). Write ``u(b) = (h(b) - V) [b in
    S] / kappa`` (the derivative of ``V`` in ``q``; ``S`` all outcomes and ``kappa = 1``
    without post-selection) and ``A = A_{m-1} (x) ... (x) A_0`` for the calibrated readout
    matrices (``A_j[r, s]``: qubit of clbit ``j`` prepared in ``s`` reads ``r``). Then

    * shots: ``V`` moves with ``p`` along ``g = A^-T u``, so their variance is
      ``Var_p(g) / N`` (the multinomial covariance ``(diag p - p p^T) / N``);
    * calibration: the error rates ``e_{j,s} = A_j[1 - s, s]`` are binomial frequencies over
      ``n_j`` calibration shots each, with ``dV/de_{j,s} = -u^T (I (x) .. A_j^-1 D_s .. (x) I)
      q`` (``D_0 = [[-1, 0], [1, 0]]``, ``D_1 = [[0, 1], [0, -1]]``, the derivatives of
      ``A_j``'s columns), adding ``sum_{j,s} (dV/de_{j,s})^2 e_{j,s} (1 - e_{j,s}) / n_j``.

    The calibration part is shared by every row (and every later job on the same mitigator),
    so the rows' errors are correlated through it. The linearisation uses the full inverse of
    ``A`` where mthree solves on the observed outcomes; both agree to first order. It assumes
    the readout errors of different qubits independent (mthree's own model); gate noise, and
    a calibration whose preparations are themselves noisy, bias ``V`` beyond this error.
    """
    check_circuit(circuit)
    obs = check_observable(observable, circuit.num_qubits)
    if np.any(obs.paulis.x):
        raise ValueError("observable must be diagonal (Z-type) for mitigated_expectation")
    if not isinstance(engine, SamplerEngine):
        raise TypeError(f"engine must be a SamplerEngine, got {type(engine).__name__}")
    if mitigator is not None and not isinstance(mitigator, ReadoutMitigator):
        raise TypeError(f"mitigator must be a ReadoutMitigator or None, got "
                        f"{type(mitigator).__name__}")
    n = circuit.num_qubits
    if postselect is not None and (isinstance(postselect, bool) or not isinstance(
            postselect, (int, np.integer)) or not 0 <= postselect <= n):
        raise ValueError(f"postselect must be None or an int in 0..{n}, got {postselect!r}")
    shots = check_positive_int(shots, "shots")
    vals = as_parameter_rows(values, circuit.num_parameters)
    job = CircuitJob(measured(circuit), vals, shots, label)
    probs = engine.run([job])[0].probabilities
    counts = np.rint(probs * shots)
    if mitigator is not None:
        qubits = _measured_qubits(engine.compiled(job.circuit), job.circuit.num_clbits)
        dist, overhead = mitigator.correct(counts, qubits)
        mats, state_shots = mitigator.readout_matrices(qubits)
    else:
        dist, overhead = counts / shots, np.ones(counts.shape[0])
        mats, state_shots = np.tile(np.eye(2), (n, 1, 1)), None
    h = diagonal_values(obs.paulis, np.real(obs.coeffs), n)
    mask = (hamming_weights(n) == postselect if postselect is not None
            else np.ones(2**n, dtype=bool))
    kept = dist[:, mask].sum(axis=1) if postselect is not None else np.ones(len(dist))
    if np.any(kept <= 0):
        raise ValueError(f"rows {np.flatnonzero(kept <= 0).tolist()} keep no outcome of "
                         f"Hamming weight {postselect}")
    value = np.where(mask[None, :], dist, 0.0) @ h / kept
    var = [_delta_variance(c / shots, shots, mats, state_shots, np.where(mask, h - v, 0.0) / k)
           for c, v, k in zip(counts, value, kept, strict=True)]
    return MitigatedEstimate(value, np.sqrt(var), np.minimum(kept, 1.0), overhead, shots)


_D = (np.array([[-1.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 1.0], [0.0, -1.0]]))


def _per_qubit(mats, vec: np.ndarray) -> np.ndarray:
    """``(mats[m-1] (x) ... (x) mats[0]) vec`` for outcomes ``b = sum_j b_j 2^j``."""
    m = len(mats)
    t = vec.reshape((2,) * m)  # axis 0 is bit m - 1
    for j, a in enumerate(mats):
        ax = m - 1 - j
        t = np.moveaxis(np.tensordot(a, t, axes=([1], [ax])), 0, ax)
    return t.reshape(-1)


def _delta_variance(p: np.ndarray, shots: int, mats: np.ndarray, state_shots,
                    u: np.ndarray) -> float:
    """``Var(V)`` by the delta method (see :func:`mitigated_expectation`'s Notes): ``p`` the
    row's frequencies (2**m,) over ``shots``, ``mats`` (m, 2, 2) the readout matrices,
    ``state_shots`` (m,) the calibration shots per prepared state (None: exact matrices),
    ``u`` the derivative of ``V`` in ``q`` (2**m,)."""
    inv = np.linalg.inv(mats)
    g = _per_qubit(inv.transpose(0, 2, 1), u)
    var = max(float(p @ g**2 - (p @ g) ** 2), 0.0)
    if state_shots is None:
        return var / shots
    q = _per_qubit(inv, p)
    eye = np.eye(2)
    cal = 0.0
    for j in range(len(mats)):
        for s in (0, 1):
            ops = [eye] * len(mats)
            ops[j] = inv[j] @ _D[s]
            dv = -float(u @ _per_qubit(ops, q))
            e = float(mats[j][1 - s, s])
            cal += dv**2 * e * (1 - e) / state_shots[j]
    return var / shots + cal
