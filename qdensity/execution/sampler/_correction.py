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

With mitigation, each row also gets a :class:`Linearisation`: the delta-method variance of
``sum_b q(b) f(b)`` over the row's shots and the calibration's shots, for whatever per-shot
``f`` a plan reads (:func:`~qdensity.execution.intervals.shot_mean` uses it). Without
mitigation (post-selection only) the weighted mean is a ratio estimator whose variance is
``Var_q(f) / (kappa N)``: the effective shots ``N_eff = min(kappa, 1) N / M`` carry it
(``M = 1``). mthree's overhead ``M`` enters ``N_eff`` too, but the standard errors of a
mitigated row come from its linearisation (``M Var_q(f) / (kappa N)`` missed the flipped shots
and the calibration on near-basis states, and overstated spread ones).
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

#: Observed outcomes per row up to which a mitigated row gets a :class:`Linearisation` (dense
#: ``u x u`` matrices on them, ~32 MB each at the cap, built when a variance is asked for; the
#: same size as mthree's own direct solve); above, its error falls back to ``N_eff``, which was
#: conservative where measured (wide registers, where ``M`` is large).
MAX_LINEARISED_OUTCOMES = 2048

#: mthree's default correction distance (``apply_correction(distance=None)``): outcomes more
#: than this many bits apart are not connected in its reduced matrix.
M3_DISTANCE = 3

_D = (np.array([[-1.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 1.0], [0.0, -1.0]]))


class Linearisation:
    """Delta-method variance of one mitigated row's corrected estimates.

    mthree solves ``W q = p`` on the ``u`` observed outcomes (its reduced matrix): ``W[i, k] =
    A[i, k] / c_k`` where ``A[i, k] = prod_j A_j[b_ij, b_kj]`` (``A_j`` the calibrated readout
    matrix of clbit ``j``'s qubit) for outcomes at most ``distance`` bits apart and 0 beyond,
    and ``c_k = sum_i A[i, k]`` (columns renormalised); ``p`` are the row's frequencies. The
    row's estimate of a per-shot function ``f`` is ``V = sum_{b in S} q(b) f(b) / kappa``
    (``S`` the kept outcomes). With ``r = (f - V) [b in S] / kappa`` and ``g = W^-T r``: shots
    contribute ``Var_p(g) / N``; each calibrated error rate ``e_{j,s}`` (a binomial frequency
    over ``n_j`` shots) contributes ``(g^T dW/de_{j,s} q)^2 e (1 - e) / n_j``, with
    ``dW/de q = dA/de q~ - A (q~ * dc/de / c)`` and ``q~ = q / c``.

    Parameters
    ----------
    outcomes : numpy.ndarray of bool, shape (u, m)
    inverse : numpy.ndarray of int, shape (shots,)
        Outcome index of every shot.
    counts : numpy.ndarray, shape (u,)
    quasi : numpy.ndarray, shape (u,)
        mthree's corrected quasi-probabilities.
    keep : numpy.ndarray of bool, shape (u,)
    kappa : float
    mats : numpy.ndarray, shape (m, 2, 2)
    state_shots : numpy.ndarray, shape (m,)
    qubits : sequence of int, length m
        Physical qubit of each clbit (names the calibrated rates).
    distance : int, optional
        mthree's correction distance (default ``min(m, 3)``, what ``apply_correction`` uses).
    """

    def __init__(self, outcomes, inverse, counts, quasi, keep, kappa, mats, state_shots,
                 qubits, distance: int | None = None):
        self.shots = int(counts.sum())
        self.inverse = np.asarray(inverse, dtype=np.int32)
        self.qubits = [int(q) for q in qubits]
        self.first = np.zeros(len(counts), dtype=int)
        self.first[inverse[::-1]] = np.arange(len(inverse))[::-1]
        self.p = counts / self.shots
        self.q = np.asarray(quasi, dtype=float)
        self.keep, self.kappa = keep, float(kappa)
        self.outcomes = np.asarray(outcomes, dtype=np.intp)
        self.mats, self.state_shots = mats, state_shots
        m = self.outcomes.shape[1]
        self.distance = min(m, M3_DISTANCE) if distance is None else int(distance)

    @property
    def kept_shots(self) -> float:
        """Shots the row's estimate rests on, ``min(kappa, 1) N`` (for the Wilson floor)."""
        return min(self.kappa, 1.0) * self.shots

    def _factor(self, j: int) -> np.ndarray:
        b = self.outcomes[:, j]
        return self.mats[j][b[:, None], b[None, :]]

    def _matrix(self) -> tuple[np.ndarray, np.ndarray]:
        """``A`` truncated at the distance ``(u, u)`` and its column sums ``c`` ``(u,)``."""
        A = np.ones((len(self.p), len(self.p)))
        for j in range(len(self.mats)):
            A *= self._factor(j)
        if self.distance < self.outcomes.shape[1]:
            o = self.outcomes.astype(float)
            A[o @ (1.0 - o).T + (1.0 - o) @ o.T > self.distance + 0.5] = 0.0
        return A, A.sum(axis=0)

    def _g(self, per_shot, mean, A, c) -> np.ndarray:
        """``g = W^-T r``, the derivative of ``V`` in the frequencies ``(u,)`` or ``(u, k)``."""
        f = np.asarray(per_shot, dtype=float)[self.first]
        r = (f - mean) * self.keep.reshape((-1,) + (1,) * (f.ndim - 1)) / self.kappa
        return np.linalg.solve((A / c).T, r)

    def calibration_gradient(self, per_shot: np.ndarray, mean, matrix=None, g=None) -> dict:
        """``{(physical qubit, prepared state): (dV/de, e, n)}`` for every calibrated error
        rate ``e`` (a binomial frequency over ``n`` shots) that can move ``V``."""
        A, c = self._matrix() if matrix is None else matrix
        g = self._g(per_shot, mean, A, c) if g is None else g
        q_c = self.q / c
        out = {}
        for j, a in enumerate(self.mats):
            fj = self._factor(j)
            b = self.outcomes[:, j]
            for s in (0, 1):
                e = float(a[1 - s, s])
                if e <= 0.0 or e >= 1.0:
                    continue  # a rate seen as 0 or 1 has no binomial spread to add
                cols = np.flatnonzero(b == s)  # dA_j[b_i, b_k]/de is 0 unless b_k = s
                rest = np.divide(A[:, cols], fj[:, cols], out=np.zeros((len(b), len(cols))),
                                 where=fj[:, cols] != 0)
                dA = rest * _D[s][b, s][:, None]
                dc = dA.sum(axis=0)
                dWq = dA @ q_c[cols] - A[:, cols] @ (q_c[cols] * dc / c[cols])
                dv = -np.tensordot(g, dWq, axes=([0], [0]))
                out[(self.qubits[j], s)] = (dv, e, int(self.state_shots[j]))
        return out

    def variance(self, per_shot: np.ndarray, mean) -> np.ndarray:
        """``Var(V)`` for per-shot values ``(shots,)`` or ``(shots, k)`` whose corrected mean
        is ``mean`` (scalar or ``(k,)``); returns a scalar or ``(k,)``."""
        A, c = self._matrix()
        g = self._g(per_shot, mean, A, c)
        var = np.maximum(np.tensordot(self.p, g**2, axes=1)
                         - np.tensordot(self.p, g, axes=1) ** 2, 0.0) / self.shots
        for dv, e, n in self.calibration_gradient(per_shot, mean, (A, c), g).values():
            var = var + dv**2 * e * (1 - e) / n
        return var

    def influence(self, per_shot: np.ndarray, mean: float) -> np.ndarray:
        """Per-shot values ``(shots,)`` whose mean is ``mean`` and whose sample variance over
        the shots is the shot part of :meth:`variance` (``mean + g(b_s) - sum_b p(b) g(b)``):
        what a scheduler that reads only per-shot values needs."""
        g = self._g(per_shot, mean, *self._matrix())
        return mean + (g - self.p @ g)[self.inverse]


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

    @classmethod
    def of_mitigator(cls, mitigator: ReadoutMitigator | None, postselect: bool
                     ) -> ReadoutCorrection:
        """The correction that applies an existing ``mitigator`` (None: no mitigation) and,
        with ``postselect``, keeps the weight the compiled circuit's metadata names."""
        out = cls(None, "hamming_weight" if postselect else None, None, 1, None)
        if mitigator is not None:
            out.mitigation, out.system = "m3", mitigator.system
            out.calibration_shots = mitigator.shots
            out._mitigator = mitigator
        return out

    def weights(self, bits: np.ndarray, compiled: QuantumCircuit, ledger
                ) -> tuple[np.ndarray, np.ndarray, list | None]:
        """Per-shot weights ``(rows, shots)``, effective shots ``(rows,)`` and, with
        mitigation, one :class:`Linearisation` per row (None for a row with more than
        :data:`MAX_LINEARISED_OUTCOMES` observed outcomes) of one job."""
        rows, shots, _ = bits.shape
        out = np.ones((rows, shots))
        n_eff = np.full(rows, float(shots))
        lins: list | None = [] if self.mitigation is not None else None
        for r in range(rows):
            out[r], kept, overhead, lin = self.row(bits[r], compiled, ledger, r)
            n_eff[r] = min(kept, 1.0) * shots / overhead
            if lins is not None:
                lins.append(lin)
        return out, n_eff, lins

    def row(self, bits: np.ndarray, compiled: QuantumCircuit, ledger, index: int = 0
            ) -> tuple[np.ndarray, float, float, Linearisation | None]:
        """One row's correction: per-shot weights ``(shots,)``, the kept (mitigated) fraction
        ``kappa``, mthree's overhead ``M`` (1 without mitigation) and, with mitigation, its
        :class:`Linearisation` (None above :data:`MAX_LINEARISED_OUTCOMES` outcomes).

        Parameters
        ----------
        bits : numpy.ndarray of bool, shape (shots, m)
        compiled : QuantumCircuit
            What was run: its measured physical qubits and the Hamming weight its metadata
            names (``HAMMING_WEIGHT_KEY``) are read.
        ledger : ShotLedger or None
            Where calibration shots go.
        index : int
            The row's index, for the message of a row that keeps no shot.
        """
        shots, m = bits.shape
        weight = (compiled.metadata or {}).get(HAMMING_WEIGHT_KEY)
        uniq, inverse, counts = np.unique(bits, axis=0, return_inverse=True,
                                          return_counts=True)
        inverse = inverse.reshape(-1)
        w = np.ones(len(uniq))
        overhead = 1.0
        qubits = None
        if self.mitigation is not None:
            qubits = _measured_qubits(compiled, m)
            keys = ["".join("1" if b else "0" for b in u[::-1]) for u in uniq]
            quasi, overhead = self.mitigator(ledger).correct_counts(
                dict(zip(keys, counts.tolist(), strict=True)), qubits)
            w = np.array([quasi.get(k, 0.0) for k in keys]) * shots / counts
        quasi_row = w * counts / shots
        keep = np.ones(len(uniq), dtype=bool)
        kept = 1.0
        if self.postselect is not None:
            keep = uniq.sum(axis=1) == weight
            w = np.where(keep, w, 0.0)
            kept = float((w * counts).sum()) / shots
            if kept <= 0:
                raise ValueError(f"row {index} kept no shot of Hamming weight {weight} "
                                 f"({shots} shots); spend more shots")
            w = w / kept
        lin = None
        if qubits is not None and len(uniq) <= MAX_LINEARISED_OUTCOMES:
            mats, state_shots = self.mitigator(ledger).readout_matrices(qubits)
            lin = Linearisation(uniq, inverse, counts, quasi_row, keep, kept, mats,
                                state_shots, qubits)
        return w[inverse], kept, overhead, lin
