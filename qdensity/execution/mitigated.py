"""Mitigated, post-selected expectation values of diagonal observables (one sampled job).

The corrections themselves live with the device (:mod:`qdensity.hardware.mitigation`: mthree's
readout mitigation and Hamming-weight post-selection); this module runs the job through a
:class:`~qdensity.execution.engines.SamplerEngine` and composes them. With ``q`` the corrected,
post-selected distribution, ``N`` shots per row, the value is ``sum_b q(b) h(b)`` and its
standard error ``sqrt(M Var_q(h) / (kappa N))``: the ``kappa N`` shots that survive
post-selection, inflated by the mitigation overhead ``M`` (mthree's own error model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.execution.engines import SamplerEngine
from qdensity.execution.plans import CircuitJob, check_observable, diagonal_values, measured
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
        ``sqrt(M Var_q(h) / (kappa N))`` (see the module docstring).
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
    else:
        dist, overhead = counts / shots, np.ones(counts.shape[0])
    h = diagonal_values(obs.paulis, np.real(obs.coeffs), n)
    if postselect is not None:
        mask = hamming_weights(n) == postselect
        kept = dist[:, mask].sum(axis=1)
        if np.any(kept <= 0):
            raise ValueError(f"rows {np.flatnonzero(kept <= 0).tolist()} keep no outcome of "
                             f"Hamming weight {postselect}")
        dist = np.where(mask[None, :], dist, 0.0) / kept[:, None]
    else:
        kept = np.ones(counts.shape[0])
    value = dist @ h
    weights = np.clip(dist, 0.0, None)
    weights /= weights.sum(axis=1, keepdims=True)
    var = np.maximum(weights @ h**2 - (weights @ h) ** 2, 0.0)
    se = np.sqrt(overhead * var / (np.minimum(kept, 1.0) * shots))
    return MitigatedEstimate(value, se, np.minimum(kept, 1.0), overhead, shots)
