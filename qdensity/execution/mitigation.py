"""Readout-error mitigation (mthree) composed with Hamming-weight post-selection.

Two corrections of sampled estimates, each optional, applied in this order:

1. **Readout-error mitigation** with mthree (M3, Nation et al., PRX Quantum 2, 040326 (2021)),
   Qiskit's maintained matrix-free readout mitigator: :class:`ReadoutMitigator` calibrates the
   physical qubits a circuit is measured on (by sampling the calibration circuits on the same
   noisy device, the shots written to the engine's ledger) and turns each row's counts into a
   quasi-probability distribution, with its *mitigation overhead* ``M >= 1`` (the factor by
   which the variance of an estimate grows).
2. **Hamming-weight post-selection**: a unary model (loaders and RBS/FBS circuits, paper
   Fig. 2 and Supp. F) keeps every ideal outcome in the Hamming-weight-1 subspace; gate noise
   leaks weight out of it. Keeping only weight-``w`` outcomes and renormalising removes that
   leak; the *kept fraction* ``kappa`` is the (mitigated) weight found there.

:func:`mitigated_expectation` estimates a diagonal (Z-type) observable ``<H> = sum_b p(b) h(b)``
this way. With ``q`` the corrected, post-selected distribution, ``N`` shots per row, the value
is ``sum_b q(b) h(b)`` and its standard error ``sqrt(M Var_q(h) / (kappa N))``: the ``kappa N``
shots that survive post-selection, inflated by the mitigation overhead (mthree's own
error model). Without mitigation ``M = 1``, without post-selection ``kappa = 1``, and the
estimate is the raw sample mean.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.execution.engines import SamplerEngine, ShotLedger
from qdensity.execution.plans import CircuitJob, check_observable, diagonal_values, measured
from qdensity.validation import (
    SeedLike,
    as_parameter_rows,
    check_circuit,
    check_positive_int,
    seed_int,
)

__all__ = ["ReadoutMitigator", "MitigatedEstimate", "mitigated_expectation",
           "hamming_weights"]


def hamming_weights(num_bits: int) -> np.ndarray:
    """Hamming weight of every outcome ``0 .. 2**num_bits - 1``.

    Parameters
    ----------
    num_bits : int

    Returns
    -------
    numpy.ndarray of int, shape (2**num_bits,)

    Examples
    --------
    >>> hamming_weights(2).tolist()
    [0, 1, 1, 2]
    """
    m = check_positive_int(num_bits, "num_bits")
    out = np.zeros(2**m, dtype=int)
    for j in range(m):
        out += (np.arange(2**m) >> j) & 1
    return out


class ReadoutMitigator:
    """mthree's M3 readout mitigation, calibrated on the device that samples the circuits.

    Parameters
    ----------
    system : qiskit.providers.BackendV2 or qdensity.targets.HardwareTarget
        Where calibration circuits run: a backend with ``run`` (an ``AerSimulator`` carrying
        a device's noise, a real device), or a target, whose noisy :meth:`simulator` is used.
    shots : int
        Shots per calibration circuit.
    seed : int or numpy.random.Generator, optional
        Seeds the target's simulator (ignored for a backend).
    ledger : ShotLedger, optional
        Calibration shots are recorded here (label ``"readout calibration"``); pass the
        engine's ledger so the account of a mitigated run is complete.

    Notes
    -----
    Qubits are calibrated lazily, the first time a correction needs them, and only once.
    """

    def __init__(self, system, *, shots: int = 4000, seed: SeedLike = None,
                 ledger: ShotLedger | None = None):
        try:
            import mthree
        except ImportError as exc:  # pragma: no cover - the extra is installed in CI
            raise ValueError("readout mitigation needs mthree; install the optional extra: "
                             "pip install 'qdensity[ibm]' (or pip install mthree)") from exc
        from qiskit.providers import BackendV2

        if hasattr(system, "simulator") and hasattr(system, "transpile"):
            system = system.simulator(seed=seed_int(seed))
        if not isinstance(system, BackendV2):
            raise TypeError(f"system must be a BackendV2 or a HardwareTarget, got "
                            f"{type(system).__name__}")
        self.system = system
        self.shots = check_positive_int(shots, "shots")
        self.ledger = ledger if ledger is not None else ShotLedger()
        self._m3 = mthree.M3Mitigation(system)
        self._calibrated: set[int] = set()

    @property
    def calibrated_qubits(self) -> list[int]:
        """Physical qubits calibrated so far."""
        return sorted(self._calibrated)

    def calibrate(self, qubits: Sequence[int]) -> None:
        """Calibrate the physical ``qubits`` not calibrated yet (records the shots spent)."""
        wanted = sorted({int(q) for q in qubits} - self._calibrated)
        if not wanted:
            return
        bad = [q for q in wanted if not 0 <= q < self.system.num_qubits]
        if bad:
            raise ValueError(f"qubits {bad} are not on the device "
                             f"(0..{self.system.num_qubits - 1})")
        jobs = self._m3.cals_from_system(wanted, shots=self.shots, async_cal=False)
        results = [exp for job in jobs for exp in job.result().results]
        self.ledger.record("readout calibration", len(results), sum(r.shots for r in results))
        self._calibrated.update(wanted)

    def correct(self, counts: np.ndarray, qubits: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Mitigated quasi-probabilities of count rows measured on physical ``qubits``.

        Parameters
        ----------
        counts : numpy.ndarray, shape (rows, 2**m)
            Counts per outcome, outcome ``sum_j b_j 2^j`` (clbit ``j`` is bit ``j``).
        qubits : sequence of int, length m
            Physical qubit measured into clbit ``j``.

        Returns
        -------
        (numpy.ndarray (rows, 2**m), numpy.ndarray (rows,))
            Quasi-probabilities (sum 1, may be slightly negative) and the mitigation overhead
            per row.
        """
        counts = np.atleast_2d(np.asarray(counts))
        m = len(qubits)
        if counts.shape[1] != 2**m:
            raise ValueError(f"counts must have 2**{m} columns for {m} qubits, got "
                             f"{counts.shape[1]}")
        self.calibrate(qubits)
        quasi = np.zeros(counts.shape, dtype=float)
        overhead = np.ones(counts.shape[0])
        for r, row in enumerate(counts):
            data = {format(b, f"0{m}b"): int(c) for b, c in enumerate(row) if c > 0}
            q = self._m3.apply_correction(data, list(qubits), return_mitigation_overhead=True)
            for key, val in q.items():
                quasi[r, int(key, 2)] = val
            overhead[r] = float(q.mitigation_overhead)
        return quasi, overhead


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


def _measured_qubits(compiled: QuantumCircuit, num_clbits: int) -> list[int]:
    """Physical qubit measured into each clbit of a compiled circuit (last measurement wins)."""
    qubit_of: dict[int, int] = {}
    for inst in compiled.data:
        if inst.operation.name == "measure":
            qubit_of[compiled.find_bit(inst.clbits[0]).index] = compiled.find_bit(
                inst.qubits[0]).index
    missing = [c for c in range(num_clbits) if c not in qubit_of]
    if missing:
        raise ValueError(f"clbits {missing} are never measured in the compiled circuit")
    return [qubit_of[c] for c in range(num_clbits)]


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
