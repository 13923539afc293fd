"""Shared base of the commuting-generator gradient circuits (paper Prop. 1, Cor. 2, Supp. F.3).

Input checks of the gradient builders (``_check_inputs``) and ``_GradientCircuits``, the
measured circuits with, per circuit, the estimator's value on every outcome: the gradient from
outcome probabilities and its standard error. Both
:class:`~qdensity.gradients.commuting.CommutingGradient` (one block) and
:class:`~qdensity.gradients.blocks.CommutingBlockGradient` (several blocks) derive from it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.analysis.blocks import _ATOL, _check_parameters
from qdensity.analysis.pauli import ZStringTable
from qdensity.execution.intervals import shot_mean, wilson_standard_error
from qdensity.execution.observables import check_observable
from qdensity.gradients._sparse import add_sparse, outputs_to_sparse, support_to_sparse
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
    _values: Sequence[ZStringTable] = field(repr=False)  # a list, or tables built on read

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
        count = self.num_gradient_circuits
        if not isinstance(bits, (list, tuple)) or len(bits) != count:
            raise ValueError(f"bits must be a list of {count} arrays, one per "
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
        count = self.num_gradient_circuits
        if count == 1 and not isinstance(probs, (list, tuple)):
            probs = [probs]
        if not isinstance(probs, (list, tuple)) or len(probs) != count:
            raise ValueError(
                f"probs must be a list of {count} arrays, one per circuit in "
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
    raw shots ``bits`` (rows, shots, width): :func:`_raw_means` of the shots' set bits."""
    rows, shots, width = bits.shape
    shot, clbit = np.nonzero(bits.reshape(rows * shots, width))
    mean, se = _raw_means([table], shot, clbit, rows, shots)
    return mean[:, 0], se[:, 0]


def _raw_means(tables, shot: np.ndarray, clbit: np.ndarray, rows: int,
               shots: int, *, support_only: bool = False) -> tuple:
    """Mean and Wilson-form error (:func:`~qdensity.execution.intervals.shot_mean`,
    ``ddof=1``) of every column of several tables on the same raw shots, from the shots' set
    bits only.

    A column's value on a shot is ``v = a - 2 y`` with ``a = sum_r c_r`` and ``y`` the sum of
    ``c_r`` over the strings with odd parity on the shot's bits (Supp. F.3). Parities are a
    sparse product (set bits x string bits), so a shot costs the strings that touch its set
    bits; the unbiased variance is summed exactly over the shots with a nonzero ``y`` entry
    plus the rest (``y = 0``) in closed form. Work ``O(rows x shots x touched strings)`` plus
    the ``(rows, T, P)`` results: never ``O(shots x width)`` per table.

    Parameters
    ----------
    tables : sequence of ZStringTable, T of them, the same width and P columns each
    shot, clbit : numpy.ndarray of int, shape (nnz,)
        Set bits: ``shot = row * shots + s`` and the clbit (column of the table's bits).
    rows, shots : int
        ``shots >= 2``.

    support_only : bool
        Return only the columns some string weighs on (the others are zero with zero error),
        never the ``(rows, T, P)`` arrays.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray), each shape (rows, T, P)
        Or, with ``support_only``, ``(support, mean, se)``: the ascending column indices
        ``t * P + p`` (S of them) and the estimates, each ``(rows, S)``.
    """
    T, P = len(tables), tables[0].num_columns
    z = np.concatenate([t.z for t in tables], axis=0)  # (M, width)
    coeffs = np.concatenate([t.coefficients for t in tables], axis=0)  # (M, P)
    table_of = np.repeat(np.arange(T), [t.z.shape[0] for t in tables])
    rr, cc = np.nonzero(coeffs)
    z_row, z_col = np.nonzero(z)
    strings = (z_row, z_col, z.shape[0], tables[0].num_qubits)
    support, mean_s, se_s = _string_means(strings, (rr, cc + table_of[rr] * P, coeffs[rr, cc]),
                                          shot, clbit, rows, shots)
    if support_only:
        return support, mean_s, se_s
    return _spread(support, mean_s, se_s, rows, T, P)


def _spread(support: np.ndarray, mean: np.ndarray, se: np.ndarray, rows: int, T: int,
            P: int) -> tuple[np.ndarray, np.ndarray]:
    """The estimates of the ``support`` columns (``t * P + p``) in dense ``(rows, T, P)``
    arrays, zero (with zero error) elsewhere."""
    full_mean = np.zeros((rows, T * P))
    full_se = np.zeros((rows, T * P))
    full_mean[:, support] = mean
    full_se[:, support] = se
    return full_mean.reshape(rows, T, P), full_se.reshape(rows, T, P)


def _string_means(strings: tuple, entries: tuple, shot: np.ndarray, clbit: np.ndarray,
                  rows: int, shots: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The work of :func:`_raw_means` on strings and coefficients given by their nonzeros.

    Parameters
    ----------
    strings : (z_row, z_col, M, width)
        The set ``Z`` bits of the ``M`` strings (string ``z_row[i]`` has a ``Z`` on qubit
        ``z_col[i]``) over outcomes of ``width`` bits.
    entries : (row, column, value)
        Coefficient ``value`` of string ``row`` in estimator ``column`` (repeats add).
    shot, clbit, rows, shots
        As :func:`_raw_means`.

    Returns
    -------
    (support, mean, se)
        The ascending estimator columns some string weighs on (S) and their estimates,
        each ``(rows, S)``.
    """
    from scipy import sparse

    z_row, z_col, M, width = strings
    rr, cols, vals = entries
    # the columns some string weighs on (the others are 0 with error 0): S of them
    support, col = np.unique(cols, return_inverse=True)
    col = col.ravel()
    S = support.size
    C = sparse.csr_matrix((vals, (rr, col)), shape=(M, S))
    # R per column: 2 sum |c_r| over the strings that vary (ZStringTable.value_range)
    varying = np.zeros(M)
    varying[z_row] = 1.0
    R = 2.0 * np.bincount(col, weights=np.abs(vals) * varying[rr], minlength=S)
    a = np.asarray(C.sum(axis=0)).ravel()  # (S,) every column's value with even parities
    B = sparse.csr_matrix((np.ones(shot.size, np.int32), (shot, clbit)),
                          shape=(rows * shots, width))
    Zt = sparse.csr_matrix((np.ones(z_row.size, np.int32), (z_col, z_row)), shape=(width, M))
    parity = (B @ Zt).tocoo()
    odd = (parity.data & 1).astype(bool)
    Odd = sparse.csr_matrix((np.ones(int(odd.sum())), (parity.row[odd], parity.col[odd])),
                            shape=(rows * shots, M))
    Y = (Odd @ C).tocoo()  # (rows * shots, S): y per shot where some odd string counts
    key = (Y.row // shots).astype(np.int64) * S + Y.col
    size = rows * S
    ybar = np.bincount(key, weights=Y.data, minlength=size) / shots
    held = np.bincount(key, minlength=size)  # shots with an entry (the rest have y = 0)
    sq = (np.bincount(key, weights=(Y.data - ybar[key]) ** 2, minlength=size)
          + (shots - held) * ybar**2)
    mean_s = a[None, :] - 2.0 * ybar.reshape(rows, S)
    se_s = wilson_standard_error(4.0 * sq.reshape(rows, S) / (shots - 1), shots, R)
    return support, mean_s, se_s


def gradients_from_results(grads, results, *, sparse: bool = False) -> tuple:
    """Every gradient of ``grads`` (one per output, the same circuits and parameters) from the
    sampled results of their shared circuits: value and standard error, each
    ``(rows, len(grads), P)``, or with ``sparse`` each a ``scipy.sparse.csr_array``
    ``(rows * len(grads), P)`` (the layout of :mod:`qdensity.gradients._sparse`) built from
    the estimated columns alone.

    Raw shots are read once per circuit (:meth:`~qdensity.execution.job_results.JobResult.
    set_clbits`) and every output's table is evaluated on them together
    (:func:`_raw_means`); corrected results (weights, readout linearisations) go through
    :meth:`_GradientCircuits.gradient_from_bits` per output.
    """
    raw = all(r.weights is None and r.readout is None for r in results)
    stacked = getattr(grads, "tables", None)  # an OutputGradients: one compact stack
    if not raw or (stacked is None
                   and len({t.num_columns for g in grads for t in g._values}) != 1):
        parts = [g.gradient_from_bits([r.bits for r in results],
                                      [r.weights for r in results],
                                      [r.effective_shots for r in results],
                                      [r.readout for r in results]) for g in grads]
        if sparse:  # one output's (rows, P) dense at a time
            return outputs_to_sparse([v for v, _ in parts], [e for _, e in parts])
        return (np.stack([v for v, _ in parts], axis=1),
                np.stack([e for _, e in parts], axis=1))
    parts = []
    for c, r in enumerate(results):
        rows, shots, _ = r.bits_shape
        if shots < 2:
            raise ValueError(f"results[{c}] needs >= 2 shots to estimate a variance")
        shot, clbit = r.set_clbits()
        if stacked is not None:  # one circuit: every output's strings by their nonzeros
            support, mean, se = _string_means(stacked.strings(), stacked.entries(), shot,
                                              clbit, rows, shots)
            P = stacked.num_columns
        else:
            tables = [g._values[c] for g in grads]
            support, mean, se = _raw_means(tables, shot, clbit, rows, shots, support_only=True)
            P = tables[0].num_columns
        parts.append(support_to_sparse(mean, se, support, len(grads), P) if sparse
                     else _spread(support, mean, se, rows, len(grads), P))
    if sparse:
        return parts[0] if len(parts) == 1 else add_sparse(parts)
    if len(parts) == 1:
        return parts[0]
    # independent circuits: estimates add, variances add
    return (sum(m for m, _ in parts), np.sqrt(sum(e**2 for _, e in parts)))
