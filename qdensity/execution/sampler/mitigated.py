"""Mitigated, post-selected expectation values of diagonal observables (one sampled job).

The corrections themselves live with the device (:mod:`qdensity.hardware.mitigation`: mthree's
readout mitigation and Hamming-weight post-selection); this module runs the job through a
:class:`~qdensity.execution.engines.SamplerEngine` and applies them with the engine's own
correction (:class:`~qdensity.execution.sampler._correction.ReadoutCorrection`, the one way
qdensity mitigates: per-shot weights and a :class:`~._correction.Linearisation` per row).
With ``q`` the corrected quasi-distribution (mthree's), ``S`` the kept outcomes and
``kappa = sum_S q`` the kept fraction, the value is ``V = sum_S q(b) h(b) / kappa``.

Its standard error is the delta method on ``V`` as a function of everything that was sampled
(:func:`mitigated_expectation` gives the formulas): the ``N`` shots of the row (a multinomial
frequency vector ``p``) and the calibration (each qubit's two readout error rates, binomial
frequencies over the calibration shots that prepared it in ``|0>`` and in ``|1>``), with
``q`` mthree's solution of ``A q = p`` on the observed outcomes for the tensor product ``A``
of the calibrated single-qubit readout matrices.
mthree's overhead heuristic ``M Var_q(h) / (kappa N)`` misses both on near-basis states (there
``Var_q(h)`` is near 0 although the flipped shots and the calibration still scatter ``V``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.execution.observables import check_observable, diagonal_values
from qdensity.execution.plans import CircuitJob, measured
from qdensity.execution.sampler._correction import ReadoutCorrection
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY
from qdensity.hardware.mitigation import ReadoutMitigator
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

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.execution.sampler.mitigated import MitigatedEstimate
    >>> est = MitigatedEstimate(np.array([0.4]), np.array([0.05]), np.array([0.9]),
    ...                         np.array([1.2]), shots=1000)
    >>> value, standard_error = est  # unpacks as an estimate does
    >>> float(standard_error[0]), float(est.kept_fraction[0])
    (0.05, 0.9)
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

    Here ``A^-1`` is the inverse of mthree's own reduced matrix on the row's observed outcomes
    (correction distance 3, columns renormalised), so the linearisation is exact for the
    solve that gave ``V`` (:class:`~qdensity.execution.sampler._correction.Linearisation`;
    above 2048 distinct outcomes per row, ``Var_q(h) M / (kappa N)``). The calibration part is
    shared by every row (and every later job on the same mitigator), so the rows' errors are
    correlated through it. It assumes
    the readout errors of different qubits independent (mthree's own model); gate noise, and
    a calibration whose preparations are themselves noisy, bias ``V`` beyond this error.

    Examples
    --------
    A loader then an RBS of angle ``t`` keep Hamming weight 1: ``<Z_0> = -cos 2t``, every shot
    kept (noiseless). At ``t = 0`` every shot reads ``e_0``, so the value is exact:

    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.execution.engines import SamplerEngine
    >>> from qdensity.execution.sampler.mitigated import mitigated_expectation
    >>> qc = QuantumCircuit(2); _ = qc.x(0); qc = qc.compose(round_robin(2))
    >>> est = mitigated_expectation(qc, SparsePauliOp("IZ"), [[0.0], [np.pi / 3]], shots=400,
    ...                             engine=SamplerEngine(seed=3, progress=False))
    >>> float(est.value[0]), float(est.standard_error[0]), est.kept_fraction.tolist()
    (-1.0, 0.0, [1.0, 1.0])
    >>> bool(abs(est.value[1] - 0.5) < 4 * est.standard_error[1])  # -cos(2 pi / 3)
    True
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
    res = engine.run([job])[0]
    # what the correction reads of the run: the measured physical qubits (mitigation) and
    # the weight to keep, through the engine's own correction (the one way qdensity mitigates)
    marker = (engine.compiled(job.circuit).copy() if mitigator is not None
              else QuantumCircuit(n, n))
    marker.metadata = {**(marker.metadata or {}), HAMMING_WEIGHT_KEY: postselect}
    correction = ReadoutCorrection.of_mitigator(mitigator, postselect is not None)
    ledger = None if mitigator is None else mitigator.ledger
    h = diagonal_values(obs.paulis, np.real(obs.coeffs), n)
    bits = res.bits
    out = np.zeros((4, bits.shape[0]))  # value, standard error, kept fraction, overhead
    for r in range(bits.shape[0]):
        w, kept, overhead, lin = correction.row(bits[r], marker, ledger, r)
        f = h[bits[r] @ (1 << np.arange(n))]
        value = float(np.mean(w * f))
        if lin is not None:
            var = float(lin.variance(f, value))
        else:  # Var_q(h) over the kept shots, min(kappa, 1) N / M of them
            var = max(float(np.mean(w * f**2)) - value**2, 0.0) * overhead / (
                min(kept, 1.0) * shots)
        out[:, r] = value, np.sqrt(var), min(kept, 1.0), overhead
    return MitigatedEstimate(out[0], out[1], out[2], out[3], shots)
