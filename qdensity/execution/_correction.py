"""Readout mitigation and Hamming-weight post-selection as a :class:`SamplerEngine` option.

Every sampled job's measured bits stay as they are; the correction adds per-shot weights
``w_s`` (mean 1 per row) so that any estimate read off the bits (a parity, a unary frequency, a
gradient estimator's value) becomes the weighted mean ``mean_s w_s f(b_s) = sum_b q(b) f(b)``
over the corrected distribution ``q``:

* ``mitigation="m3"``: mthree corrects each row's counts over the outcomes that were observed
  (matrix-free, so any width) to a quasi-distribution ``q``; a shot of outcome ``b`` gets
  ``w = q(b) N / count(b)``. mthree also gives the mitigation overhead ``M >= 1``.
* ``postselect="hamming_weight"``: shots whose Hamming weight differs from the weight the
  ideal circuit keeps (read off its gates) get weight 0; the rest are rescaled by the kept
  (mitigated) fraction ``kappa``.

The effective shots ``N_eff = min(kappa, 1) N / M`` carry the standard errors
(:func:`~qdensity.execution.intervals.shot_mean`).
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.hardware.aer_sampling import HAMMING_WEIGHT_KEY
from qdensity.hardware.mitigation import (
    MITIGATIONS,
    POSTSELECTIONS,
    ReadoutMitigator,
    _measured_qubits,
    fixed_hamming_weight,
)
from qdensity.validation import check_positive_int

__all__: list[str] = []


class ReadoutCorrection:
    """The mitigation and post-selection settings of one engine (the mitigator is built on
    first use and not pickled: an unpickled engine calibrates again, on its ledger)."""

    def __init__(self, mitigation, postselect, system, calibration_shots: int, seed):
        if mitigation is not None and mitigation not in MITIGATIONS:
            raise ValueError(f"mitigation must be None or one of {list(MITIGATIONS)}, got "
                             f"{mitigation!r}")
        if postselect is not None and postselect not in POSTSELECTIONS:
            raise ValueError(f"postselect must be None or one of {list(POSTSELECTIONS)}, got "
                             f"{postselect!r}")
        if mitigation is not None and system is None:
            raise ValueError(
                f"mitigation={mitigation!r} needs a device to calibrate the readout on: pass "
                f"target= (a noisy target name, backend, Target with a noise model, or snapshot "
                f"file) or a provider's sampler that names its backend")
        self.mitigation = mitigation
        self.postselect = postselect
        self.system = system
        self.calibration_shots = check_positive_int(calibration_shots, "calibration_shots")
        self.seed = seed
        self._mitigator: ReadoutMitigator | None = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_mitigator"] = None
        return state

    def mitigator(self, ledger) -> ReadoutMitigator:
        """The engine's M3 mitigator (calibration shots go on ``ledger``)."""
        if self._mitigator is None:
            self._mitigator = ReadoutMitigator(self.system, shots=self.calibration_shots,
                                               seed=self.seed, ledger=ledger)
        self._mitigator.ledger = ledger
        return self._mitigator

    def check(self, template: QuantumCircuit, compiled: QuantumCircuit, label: str) -> None:
        """Refuse, before anything is submitted, a job this correction cannot apply to."""
        if self.postselect is not None and (compiled.metadata or {}).get(
                HAMMING_WEIGHT_KEY) is None:
            fixed_hamming_weight(template, label)  # raises, naming what is supported
        if self.mitigation is not None:
            try:
                _measured_qubits(compiled, compiled.num_clbits)
            except ValueError as exc:
                raise ValueError(f"mitigation={self.mitigation!r} cannot mitigate job {label!r}: "
                                 f"{exc}; M3 mitigates circuits whose every clbit is measured "
                                 f"once") from exc

    def weights(self, bits: np.ndarray, compiled: QuantumCircuit, ledger
                ) -> tuple[np.ndarray, np.ndarray]:
        """Per-shot weights ``(rows, shots)`` and effective shots ``(rows,)`` of one job."""
        rows, shots, m = bits.shape
        weight = (compiled.metadata or {}).get(HAMMING_WEIGHT_KEY)
        qubits = (_measured_qubits(compiled, m) if self.mitigation is not None else None)
        out = np.ones((rows, shots))
        n_eff = np.full(rows, float(shots))
        for r in range(rows):
            uniq, inverse, counts = np.unique(bits[r], axis=0, return_inverse=True,
                                              return_counts=True)
            inverse = inverse.reshape(-1)
            w = np.ones(len(uniq))
            overhead = 1.0
            if qubits is not None:
                keys = ["".join("1" if b else "0" for b in u[::-1]) for u in uniq]
                quasi, overhead = self.mitigator(ledger).correct_counts(
                    dict(zip(keys, counts.tolist(), strict=True)), qubits)
                w = np.array([quasi.get(k, 0.0) for k in keys]) * shots / counts
            kept = 1.0
            if self.postselect is not None:
                w = np.where(uniq.sum(axis=1) == weight, w, 0.0)
                kept = float((w * counts).sum()) / shots
                if kept <= 0:
                    raise ValueError(f"row {r} kept no shot of Hamming weight {weight} "
                                     f"({shots} shots); spend more shots")
                w = w / kept
            out[r] = w[inverse]
            n_eff[r] = min(kept, 1.0) * shots / overhead
        return out, n_eff
