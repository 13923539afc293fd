"""Shared base of the commuting-generator gradient circuits (paper Prop. 1, Cor. 2, Supp. F.3).

Input checks of the gradient builders (``_check_inputs``) and ``_GradientCircuits``, the
measured circuits with, per circuit, the estimator's value on every outcome: the gradient from
outcome probabilities and its standard error. Both
:class:`~qdensity.gradients.commuting.CommutingGradient` (one block) and
:class:`~qdensity.gradients.blocks.CommutingBlockGradient` (several blocks) derive from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.analysis.blocks import _ATOL, _check_parameters
from qdensity.analysis.pauli import ZStringTable
from qdensity.execution.intervals import shot_mean, wilson_standard_error
from qdensity.execution.plans import check_observable
from qdensity.validation import check_circuit, check_rows_sum_to_one


def _check_inputs(circuit, observable, parameters, diagonaliser):
    """Shared checks of the commuting-gradient builders: (params, observable)."""
    check_circuit(circuit)
    if circuit.num_clbits:
        raise ValueError(
            f"circuit must have no classical bits (it is measured here), got {circuit.num_clbits}"
        )
    if diagonaliser not in ("auto", "rbs", "clifford"):
        raise ValueError(
            f"diagonaliser must be 'auto', 'rbs' or 'clifford', got {diagonaliser!r}"
        )
    params = _check_parameters(circuit, parameters)
    if not isinstance(observable, SparsePauliOp):
        raise TypeError(f"observable must be a SparsePauliOp, got {type(observable).__name__}")
    op = check_observable(observable, circuit.num_qubits).simplify(atol=_ATOL)
    return params, SparsePauliOp(op.paulis, op.coeffs.real.astype(complex))


def _check_probs(probs, dim: int, name: str = "probs") -> np.ndarray:
    try:
        arr = np.asarray(probs, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of probabilities, got {probs!r}") from exc
    if arr.ndim not in (1, 2) or arr.shape[-1] != dim:
        raise ValueError(
            f"{name} must have shape ({dim},) or (rows, {dim}) (one probability per measured "
            f"bitstring, index = integer with clbit j as bit j), got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    check_rows_sum_to_one(arr, name)
    return arr


def _check_shots(shots, rows: int) -> np.ndarray:
    arr = np.asarray(shots)
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"shots must be an int or an integer array, got {shots!r}")
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != rows):
        raise ValueError(f"shots must be an int or have shape ({rows},), got shape {arr.shape}")
    if np.any(arr < 2):
        raise ValueError(f"shots must be >= 2 to estimate a variance, got {shots!r}")
    return np.broadcast_to(arr.astype(float), (rows,))


@dataclass
class _GradientCircuits:
    """Measured circuits and, per circuit, the estimator's value on every outcome."""

    circuits: list[QuantumCircuit]
    parameters: list[Parameter]
    _values: list[ZStringTable] = field(repr=False)

    @property
    def num_gradient_circuits(self) -> int:
        """Distinct circuits per data point (``len(circuits)``)."""
        return len(self.circuits)

    def value_matrices(self) -> list[np.ndarray]:
        """Per circuit, shape ``(2**width, P)``: each parameter's estimator on each outcome.

        Dense, so only up to :data:`~qdensity.validation.MAX_DENSE_QUBITS` qubits; wider
        circuits are estimated from sampled bits (:meth:`gradient_from_bits`)."""
        return [v.dense() for v in self._values]

    def gradient_from_bits(self, bits, weights=None, effective_shots=None,
                           readout=None) -> tuple[np.ndarray, np.ndarray]:
        """Gradient and standard error from the measured bits, never a ``2**n`` array.

        Each shot gives one value of every parameter's estimator (parities of its bits); the
        estimate is their mean, the error ``sqrt(s^2 / N + R^2 / (4 N^2))`` with ``s^2`` the
        unbiased sample variance and ``R`` the estimator's range (never zero, even when every
        shot agrees); independent circuits add. Memory ``O(shots x P)`` per row.

        Parameters
        ----------
        bits : sequence of numpy.ndarray of bool, each shape (rows, shots, width)
            Per circuit, in :attr:`circuits` order (clbit ``j`` = column ``j``).
        weights, effective_shots : sequence, optional
            Per circuit, a corrected run's per-shot weights ``(rows, shots)`` and effective
            shots ``(rows,)`` (``JobResult.weights``, ``JobResult.effective_shots``; None for a
            raw circuit): the estimate and its error are then
            :func:`~qdensity.execution.intervals.shot_mean`'s weighted ones.
        readout : sequence, optional
            Per circuit, a mitigated run's per-row linearisations (``JobResult.readout``).

        Returns
        -------
        (numpy.ndarray, numpy.ndarray), each shape (rows, P)
        """
        if not isinstance(bits, (list, tuple)) or len(bits) != len(self.circuits):
            raise ValueError(f"bits must be a list of {len(self.circuits)} arrays, one per "
                             "circuit in `circuits` order")
        value: float | np.ndarray = 0.0
        var: float | np.ndarray = 0.0
        for c, (b, table) in enumerate(zip(bits, self._values, strict=True)):
            b = np.asarray(b)
            if b.ndim != 3 or b.shape[-1] != table.num_qubits:
                raise ValueError(f"bits[{c}] must have shape (rows, shots, "
                                 f"{table.num_qubits}), got {b.shape}")
            if b.shape[1] < 2:
                raise ValueError(f"bits[{c}] needs >= 2 shots to estimate a variance")
            w = None if weights is None else weights[c]
            lin = None if readout is None else readout[c]
            if w is None and lin is None:  # raw shots: one value per distinct outcome
                mean, se = _raw_mean(table, b)
            else:
                rows = np.stack([table.on_bits(r) for r in b]) if b.shape[0] else np.zeros(
                    (0, b.shape[1], table.num_columns))
                mean, se = shot_mean(rows, table.value_range(), weights=w, ddof=1,
                                     effective_shots=None if w is None else effective_shots[c],
                                     linearisations=lin)
            value = value + mean
            var = var + se**2
        return np.asarray(value), np.sqrt(var)

    def _as_list(self, probs) -> list[np.ndarray]:
        if len(self.circuits) == 1 and not isinstance(probs, (list, tuple)):
            probs = [probs]
        if not isinstance(probs, (list, tuple)) or len(probs) != len(self.circuits):
            raise ValueError(
                f"probs must be a list of {len(self.circuits)} arrays, one per circuit in "
                "`circuits` order (a single array is accepted when there is one circuit)"
            )
        arrs = [
            _check_probs(p, 2**v.num_qubits, f"probs[{c}]")
            for c, (p, v) in enumerate(zip(probs, self._values, strict=True))
        ]
        if len({a.shape[:-1] for a in arrs}) != 1:
            raise ValueError("the probability arrays must all have the same number of rows")
        return arrs

    def gradient_from_probabilities(self, probs) -> np.ndarray:
        """Gradient from the outcome probabilities of the circuits.

        Parameters
        ----------
        probs : array_like or sequence of array_like
            Per circuit, shape ``(rows, 2**width)`` or ``(2**width,)``: exact or empirical
            probability of each measured bitstring, index = integer of the bitstring with
            clbit ``j`` as bit ``j``. A single array when there is one circuit.

        Returns
        -------
        numpy.ndarray, shape (rows, P) or (P,)
            ``d f / d p`` for each parameter of :attr:`parameters`.
        """
        arrs = self._as_list(probs)
        return sum(a @ v for a, v in zip(arrs, self.value_matrices(), strict=True))

    def standard_error(self, probs, shots) -> np.ndarray:
        """Standard error of each gradient estimate.

        Each shot of a circuit gives one value of every parameter's estimator; per circuit the
        error is ``s^2 / shots`` with ``s^2`` the unbiased sample variance of those values
        (``shots / (shots - 1)`` times the variance under ``probs``), in the Wilson form of
        :func:`qdensity.execution.intervals.wilson_standard_error` so that it never collapses to
        zero when every shot gave the same value; independent circuits add.

        Parameters
        ----------
        probs : array_like or sequence of array_like
            Empirical frequencies, as in :meth:`gradient_from_probabilities`.
        shots : int or sequence of int
            Shots per circuit (one int for all circuits, or one per circuit), each ``>= 2``.

        Returns
        -------
        numpy.ndarray, shape (rows, P) or (P,)
        """
        arrs = self._as_list(probs)
        per_circuit = [shots] * len(arrs) if np.ndim(shots) == 0 else list(shots)
        if len(per_circuit) != len(arrs):
            raise ValueError(
                f"shots must be an int or one int per circuit ({len(arrs)}), got {shots!r}"
            )
        total: float | np.ndarray = 0.0
        for a, v, s in zip(arrs, self.value_matrices(), per_circuit, strict=True):
            two_d = np.atleast_2d(a)
            n_shots = _check_shots(s, two_d.shape[0])
            mean = two_d @ v
            var = np.maximum(two_d @ v**2 - mean**2, 0.0)  # rounding can give -1e-17
            n = n_shots[:, None].astype(float)
            width = v.max(axis=0) - v.min(axis=0)  # range of each parameter's per-shot value
            total = total + wilson_standard_error(var * n / (n - 1.0), n, width) ** 2
        se = np.sqrt(total)
        return se if arrs[0].ndim == 2 else se[0]


def _raw_mean(table, bits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~qdensity.execution.intervals.shot_mean` (``ddof=1``) of ``table``'s values on
    raw shots ``bits`` (rows, shots, width), computed on each row's distinct outcomes with
    their counts: the same mean and unbiased variance, at the cost of the outcomes the rows
    saw (a few per row for a Hamming-weight circuit) instead of every shot. Outcomes are told
    apart exactly: their bits packed into 64-bit words, sorted once for all rows."""
    rows, shots, width = bits.shape
    packed = np.packbits(bits, axis=-1)
    pad = -packed.shape[-1] % 8
    if pad:
        packed = np.concatenate([packed, np.zeros(packed.shape[:-1] + (pad,), np.uint8)], -1)
    words = np.ascontiguousarray(packed).view(np.uint64).reshape(rows * shots, -1)
    row_of = np.repeat(np.arange(rows), shots)
    order = np.lexsort(tuple(words[:, i] for i in range(words.shape[1] - 1, -1, -1))
                       + (row_of,))
    ordered, ordered_row = words[order], row_of[order]
    new = np.ones(order.size, dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1) | (ordered_row[1:] != ordered_row[:-1])
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, order.size)).astype(float)
    row = ordered_row[starts]
    vals = table.on_bits(bits.reshape(rows * shots, width)[order[starts]])  # (U, P)
    mean = np.zeros((rows, vals.shape[1]))
    np.add.at(mean, row, counts[:, None] * vals)
    mean /= shots
    var = np.zeros_like(mean)
    np.add.at(var, row, counts[:, None] * (vals - mean[row]) ** 2)
    var /= shots - 1
    return mean, wilson_standard_error(var, shots, table.value_range())
