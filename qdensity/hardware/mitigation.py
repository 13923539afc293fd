"""Readout-error mitigation (mthree) and Hamming-weight post-selection.

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

:func:`qdensity.execution.mitigated.mitigated_expectation` estimates a diagonal (Z-type)
observable ``<H> = sum_b p(b) h(b)`` this way. With ``q`` the corrected, post-selected
distribution, ``N`` shots per row, the value is ``sum_b q(b) h(b)`` and its standard error
``sqrt(M Var_q(h) / (kappa N))``: the ``kappa N`` shots that survive post-selection, inflated
by the mitigation overhead (mthree's own error model). Without mitigation ``M = 1``, without
post-selection ``kappa = 1``, and the estimate is the raw sample mean.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.validation import SeedLike, check_positive_int, seed_int

__all__ = ["ReadoutMitigator", "hamming_weights"]


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
    ledger : qdensity.engines.ShotLedger, optional
        Calibration shots are recorded here (label ``"readout calibration"``, through its
        ``record(label, circuits, shots)``); pass the engine's ledger so the account of a
        mitigated run is complete. Without one they are counted in
        :attr:`calibration_shots` only.

    Notes
    -----
    Qubits are calibrated lazily, the first time a correction needs them, and only once.
    """

    def __init__(self, system, *, shots: int = 4000, seed: SeedLike = None,
                 ledger=None):
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
        if ledger is not None and not callable(getattr(ledger, "record", None)):
            raise TypeError(f"ledger must be a ShotLedger (with record(label, circuits, "
                            f"shots)) or None, got {type(ledger).__name__}")
        self.ledger = ledger
        #: Calibration shots spent so far.
        self.calibration_shots = 0
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
        spent = sum(r.shots for r in results)
        self.calibration_shots += spent
        if self.ledger is not None:
            self.ledger.record("readout calibration", len(results), spent)
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
