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

:func:`qdensity.execution.sampler.mitigated.mitigated_expectation` estimates a diagonal (Z-type)
observable ``<H> = sum_b p(b) h(b)`` this way. With ``q`` the corrected, post-selected
distribution, the value is ``sum_b q(b) h(b)``; its standard error is the delta method over
the row's shots and the calibration's shots (:meth:`ReadoutMitigator.readout_matrices` gives
the calibrated matrices and the shots behind them). Without mitigation and post-selection the
estimate is the raw sample mean.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.analysis.gate_registry import GATES
from qdensity.analysis.structure import HW_PRESERVING_GATES, is_hamming_weight_preserving
from qdensity.validation import SeedLike, check_positive_int, seed_int

__all__ = ["ReadoutMitigator", "hamming_weights", "fixed_hamming_weight", "MITIGATIONS",
           "POSTSELECTIONS"]

#: Readout mitigations a :class:`~qdensity.execution.engines.SamplerEngine` applies.
MITIGATIONS = ("m3",)
#: Post-selections a :class:`~qdensity.execution.engines.SamplerEngine` applies.
POSTSELECTIONS = ("hamming_weight",)


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
    system : qiskit.providers.BackendV2 or qdensity.hardware.targets.HardwareTarget
        Where calibration circuits run: a backend with ``run`` (an ``AerSimulator`` carrying
        a device's noise, a real device), or a target, whose noisy :meth:`simulator` is used.
    shots : int
        Shots per calibration circuit.
    seed : int or numpy.random.Generator, optional
        Seeds the target's simulator (ignored for a backend).
    ledger : qdensity.execution.engines.ShotLedger, optional
        Calibration shots are recorded here (label ``"readout calibration"``, through its
        ``record(label, circuits, shots)``); pass the engine's ledger so the account of a
        mitigated run is complete. Without one they are counted in
        :attr:`calibration_shots` only.

    Notes
    -----
    Qubits are calibrated lazily, the first time a correction needs them, and only once.

    Examples
    --------
    Calibrated on a noiseless simulator, the correction leaves the counts as they are:

    >>> from qiskit_aer import AerSimulator
    >>> mit = ReadoutMitigator(AerSimulator(), shots=100, seed=1)
    >>> probs, _ = mit.correct_counts({"01": 30, "10": 70}, [0, 1])
    >>> {k: round(float(v), 6) for k, v in sorted(probs.items())}, mit.calibrated_qubits
    ({'01': 0.3, '10': 0.7}, [0, 1])
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
        self._state_shots: dict[int, int] = {}

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
        # shots in which each qubit was prepared in |0> (and as many in |1>): mthree's
        # 'independent' calibration (simulators) runs two circuits per qubit, its 'balanced'
        # and 'marginal' ones prepare every qubit in each state in half of all the shots
        per_state = (spent // (2 * len(wanted)) if self._m3.cal_method == "independent"
                     else spent // 2)
        self._state_shots.update(dict.fromkeys(wanted, per_state))
        if self.ledger is not None:
            self.ledger.record("readout calibration", len(results), spent)
        self._calibrated.update(wanted)

    def readout_matrices(self, qubits: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """The calibrated single-qubit readout matrices and the shots each entry rests on.

        Parameters
        ----------
        qubits : sequence of int, length m
            Physical qubits (calibrated first if needed).

        Returns
        -------
        (numpy.ndarray (m, 2, 2), numpy.ndarray of int (m,))
            ``A[j][r, s]``: the estimated probability that qubit ``qubits[j]`` prepared in
            ``s`` reads ``r`` (columns sum to 1); and the calibration shots in which it was
            prepared in each state (each column is a binomial frequency over that many shots).
        """
        self.calibrate(qubits)
        mats = np.array([np.asarray(self._m3.single_qubit_cals[int(q)], dtype=float)
                         for q in qubits]).reshape(len(qubits), 2, 2)
        return mats, np.array([self._state_shots[int(q)] for q in qubits], dtype=int)

    def correct_counts(self, counts: dict, qubits: Sequence[int]) -> tuple[dict, float]:
        """Mitigated quasi-probabilities of one row's counts, over its observed outcomes.

        Parameters
        ----------
        counts : dict
            ``{bitstring: count}``, clbit ``m - 1`` first (Qiskit's order), any width.
        qubits : sequence of int, length m
            Physical qubit measured into clbit ``j``.

        Returns
        -------
        (dict, float)
            ``{bitstring: quasi-probability}`` (sums to 1, may be slightly negative) and the
            mitigation overhead ``M``.
        """
        self.calibrate(qubits)
        q = self._m3.apply_correction(counts, list(qubits), return_mitigation_overhead=True)
        return dict(q), float(q.mitigation_overhead)

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


_FLIPS = frozenset({"x", "y"})  # on a definite bit: flip it (a phase does not matter)
_DIAGONAL = frozenset(name for name, kind in GATES.items() if kind.diagonal)  # the registry's
_IGNORED = frozenset({"measure", "barrier", "delay"})


def _preserving_leaf(op) -> bool:
    if op.name in HW_PRESERVING_GATES:
        return True
    if op.definition is not None:
        return False  # followed through its definition
    qc = QuantumCircuit(op.num_qubits)
    qc.append(op, range(op.num_qubits))
    return is_hamming_weight_preserving(qc)


def _walk(circuit: QuantumCircuit, qubits: list[int], bits: list, label: str,
          top: str | None = None) -> int:
    """Follow ``circuit`` on ``qubits`` (bits: 0/1 while a basis state, None once mixed);
    returns the change of the Hamming weight."""
    change = 0
    for inst in circuit.data:
        op = inst.operation
        qs = [qubits[circuit.find_bit(q).index] for q in inst.qubits]
        if op.name in _IGNORED or op.name in _DIAGONAL:
            continue
        if op.name in _FLIPS and bits[qs[0]] is not None:
            bits[qs[0]] ^= 1
            change += 1 if bits[qs[0]] else -1
        elif _preserving_leaf(op):
            for q in qs:
                bits[q] = None
        elif op.definition is not None:
            change += _walk(op.definition, qs, bits, label, top or op.name)
        else:
            raise ValueError(
                f"postselect='hamming_weight' cannot post-select job {label!r}: its gate "
                f"{top or op.name!r} does not keep the Hamming weight fixed; supported are X "
                f"gates on |0...0> followed by Hamming-weight-preserving gates ("
                f"{', '.join(sorted(HW_PRESERVING_GATES - _IGNORED))}), measured in the Z "
                f"basis (unary probabilities, Z-type observables)")
    return change


def fixed_hamming_weight(circuit: QuantumCircuit, label: str | None = None) -> int:
    """The Hamming weight every ideal outcome of ``circuit`` (run on ``|0...0>``) has.

    Read off the gates: X (or Y) gates on qubits still in a basis state flip them, then only
    Hamming-weight-preserving gates (RBS, FBS, ``xx_plus_yy``, phases, ...) may act; composite
    gates (loaders) are followed through their definitions.

    Parameters
    ----------
    circuit : QuantumCircuit
        Measured or not.
    label : str, optional
        Names the job in the error message.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        A gate that does not keep the weight fixed (a basis rotation for an X or Y
        observable, a Hadamard, a ``ry``, an X on a mixed qubit ...): such a readout cannot be
        post-selected on its Hamming weight; the message names what is supported.

    Examples
    --------
    >>> from qdensity.circuits.loaders import unary_loader
    >>> fixed_hamming_weight(unary_loader([0.6, 0.8, 0.0]))
    1
    """
    bits: list = [0] * circuit.num_qubits
    return _walk(circuit, list(range(circuit.num_qubits)), bits, label or circuit.name)
