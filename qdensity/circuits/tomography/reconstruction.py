"""Signed unary amplitudes from tomography counts (Supp. F): counts, result, reconstruction.

Count handling (Qiskit bitstrings, ints or a one-row ``BitArray``; post-selection on the
unary outcomes), :class:`TomographyResult`, the signed union-find that propagates relative
signs along significant edges, :func:`reconstruct`, and :func:`bridge_pairs` to close gaps.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from qdensity.circuits.tomography._common import (
    _check_pairs,
    _layer_pairs,
    _sqrt_error,
)
from qdensity.circuits.tomography.bounds import SIGN_FACTOR
from qdensity.validation import (
    Array,
    Instance,
    Interval,
    Qubits,
    SequenceOf,
    Unchecked,
    validates,
)

__all__ = ["TomographyResult", "reconstruct", "bridge_pairs"]


# ----------------------------------------------------------------------------- counts
def _unary_counts(counts, num_qubits: int, name: str) -> tuple[np.ndarray, float]:
    """Counts of the unary outcomes ``e_j`` (shape (n,)) and the total number of shots."""
    n = num_qubits
    if not isinstance(counts, Mapping) and hasattr(counts, "get_counts"):
        width = getattr(counts, "num_bits", n)
        if width != n:
            raise ValueError(f"{name} has {width} bits per shot but num_qubits is {n}")
        rows = int(np.prod(getattr(counts, "shape", ())))
        if rows != 1:
            raise ValueError(
                f"{name} is a BitArray with {rows} parameter rows; pass one row's counts "
                "(bit_array.get_counts(row)) so that different rows are not merged"
            )
        counts = counts.get_counts()
    if not isinstance(counts, Mapping):
        raise TypeError(
            f"{name} must be a counts mapping (outcome -> count), got {type(counts).__name__}"
        )
    unary = np.zeros(n)
    total = 0.0
    for key, value in counts.items():
        if isinstance(key, str):
            text = key.replace("_", "")
            if text.lower().startswith("0x"):
                try:
                    outcome = int(text, 16)
                except ValueError as exc:
                    raise ValueError(f"{name} has an invalid hex key {key!r}") from exc
            else:
                if len(text) != n or set(text) - {"0", "1"}:
                    raise ValueError(
                        f"{name} key {key!r} is not a {n}-bit string of 0/1 (num_qubits={n}); "
                        "counts of a different width or with several registers are refused"
                    )
                outcome = int(text, 2)
        elif isinstance(key, numbers.Integral) and not isinstance(key, bool):
            outcome = int(key)
        else:
            raise TypeError(f"{name} keys must be bitstrings or ints, got {key!r}")
        if not 0 <= outcome < 2**n:
            raise ValueError(
                f"{name} key {key!r} is outside the {n}-qubit outcomes 0 .. {2**n - 1}"
            )
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise TypeError(f"{name}[{key!r}] must be a non-negative number, got {value!r}")
        value = float(value)
        if not math.isfinite(value) or value < 0:
            raise ValueError(f"{name}[{key!r}] must be a non-negative count, got {value!r}")
        total += value
        if outcome and not outcome & (outcome - 1):
            unary[outcome.bit_length() - 1] += value
    if total <= 0:
        raise ValueError(f"{name} has zero total shots; every circuit needs at least one shot")
    return unary, total


def _counts_list(counts) -> list:
    if len(counts) != 3:
        raise ValueError(
            f"counts must hold exactly 3 counts mappings (Z, even-pair and odd-pair circuits), "
            f"got {len(counts)}"
        )
    return list(counts)


def _shots_value(total: float) -> int | float:
    return int(total) if float(total).is_integer() else float(total)


# ----------------------------------------------------------------------------- result
@validates(
    amplitudes=Array(ndim=1), magnitudes=Array(ndim=1), signs=Array(ndim=1), shots=Instance(tuple),
    kept_fraction=Instance(tuple), error_estimate=Interval(float, 0), components=Instance(tuple),
    negligible=Instance(tuple), magnitude_error=Interval(float, 0), delta=Interval(float, 0),
    p_fail=Interval(float, 0, 1, closed='neither'),
)
@dataclass(frozen=True)
class TomographyResult:
    """Outcome of :func:`reconstruct`.

    Attributes
    ----------
    amplitudes : numpy.ndarray, shape (n,)
        Signed estimate ``signs * magnitudes`` (global sign: largest amplitude positive).
    magnitudes : numpy.ndarray, shape (n,)
        ``sqrt(p_hat_j)`` from circuit 0.
    signs : numpy.ndarray of int, shape (n,)
        ``+1`` / ``-1``.
    shots : tuple of int or float
        Total counts of each circuit (3, then one per extra circuit).
    kept_fraction : tuple of float
        Fraction of each circuit's shots used (the Hamming-weight-1 outcomes when
        post-selecting; ``1.0`` otherwise).
    error_estimate : float
        l-infinity error bound on ``amplitudes`` (up to the global sign) that holds with
        probability ``>= 1 - p_fail``: ``t0`` (the magnitude error) when all non-negligible
        amplitudes are sign-connected, else ``t0 + 2 max |y_hat_j|`` over indices outside the
        reference component (an undetermined relative sign can cost that much).
    components : tuple of tuple of int
        Groups of indices whose relative signs were determined and matter: the reference
        group (containing the largest amplitude) first, then any group left unconnected to it
        whose sign could move the error above ``delta``. ``len(components) == 1`` means the
        signs are resolved; otherwise add bridge circuits (:func:`bridge_pairs`).
    negligible : tuple of int
        Indices outside the reference group too small for their sign to matter within
        ``delta``; their group's largest member is taken positive.
    magnitude_error : float
        ``t0``, the high-probability bound on ``| |y_hat_j| - |y_j| |``.
    delta : float
        Tolerance used to decide which groups matter.
    p_fail : float
        Failure probability of the bounds.

    Examples
    --------
    >>> res = reconstruct([{"01": 64, "10": 36}, {"01": 2, "10": 98}, {"01": 64, "10": 36}], 2)
    >>> isinstance(res, TomographyResult), res.amplitudes.shape
    (True, (2,))
    """

    amplitudes: np.ndarray
    magnitudes: np.ndarray
    signs: np.ndarray
    shots: tuple
    kept_fraction: tuple
    error_estimate: float
    components: tuple
    negligible: tuple = field(default=())
    magnitude_error: float = 0.0
    delta: float = 0.0
    p_fail: float = 0.01

    @property
    def signs_resolved(self) -> bool:
        """True when one sign component covers every non-negligible amplitude."""
        return len(self.components) <= 1


class _SignedUnionFind:
    """Union-find that also tracks the relative sign of each node to its root."""

    def __init__(self, size: int):
        self.parent = list(range(size))
        self.parity = [0] * size  # 0: same sign as parent, 1: opposite

    def find(self, a: int) -> tuple[int, int]:
        parity = 0
        node = a
        while self.parent[node] != node:
            parity ^= self.parity[node]
            node = self.parent[node]
        return node, parity

    def union(self, a: int, b: int, opposite: int) -> None:
        ra, pa = self.find(a)
        rb, pb = self.find(b)
        if ra != rb:
            self.parent[rb] = ra
            self.parity[rb] = pa ^ pb ^ opposite


@validates(
    counts=Instance((list, tuple), 'list of the three circuits\' counts (mappings or BitArrays)'),
    num_qubits=Qubits(2), postselect=Instance(bool),
    delta=[Interval(float, 0, None, closed='neither'), None],
    p_fail=Interval(float, 0, 1, closed='neither'),
    extra=[SequenceOf(Unchecked('each (pairs, counts) checked in the body'), min_len=0), None],
)
def reconstruct(
    counts: Sequence,
    num_qubits: int,
    *,
    postselect: bool = True,
    delta: float | None = None,
    p_fail: float = 0.01,
    extra: Sequence[tuple[Sequence[tuple[int, int]], Mapping]] | None = (),
) -> TomographyResult:
    """Estimate the signed unary amplitudes from the counts of the tomography circuits.

    Parameters
    ----------
    counts : sequence of 3 counts mappings
        Counts of :func:`tomography_circuits`' circuits, in order (Z, even pairs, odd
        pairs). Keys: ``num_qubits``-bit strings (qubit 0 rightmost) or ints; values:
        non-negative numbers (a ``SamplerV2`` ``BitArray`` is also accepted).
    num_qubits : int
        ``n >= 2``.
    postselect : bool
        Keep only Hamming-weight-1 outcomes and renormalise over them (mitigates readout and
        gate errors that leave the unary subspace). If False every shot counts, and the
        estimate is of the un-renormalised unary amplitudes.
    delta : float, optional
        Tolerance for "too small to matter": an unconnected group whose worst-case sign error
        ``t0 + 2 max |y_hat|`` is at most ``delta`` is negligible. Default
        ``(1 + 4 sqrt 2) t0``, the error :func:`shots_for_error` plans for.
    p_fail : float
        Failure probability of all the bounds together (union bound).
    extra : sequence of (pairs, counts)
        Bridge circuits (:func:`bridge_circuit`) and their counts, joining sign components
        across gaps.

    Returns
    -------
    TomographyResult

    Notes
    -----
    With ``K_c`` kept shots in circuit ``c`` and ``E = n * (number of circuits)`` events,
    ``t_c = sqrt(ln(2 E / p_fail) / K_c)`` bounds every ``|sqrt(q_hat) - sqrt(q)|`` of circuit
    ``c`` with probability ``>= 1 - p_fail`` (derivation in :func:`shots_for_error`). An edge
    ``(a, b)`` of circuit ``c`` is significant when ``|D_hat_ab| > 2 sqrt(2) t_c``; signs are
    joined along significant edges, most significant first, from the largest magnitude.

    Raises
    ------
    ValueError
        Not 3 mappings, keys of another width or out of range, negative counts, zero total
        shots, no Hamming-weight-1 outcome to post-select, invalid ``extra`` pairs.

    Examples
    --------
    >>> res = reconstruct([{"01": 64, "10": 36}, {"01": 2, "10": 98}, {"01": 64, "10": 36}], 2)
    >>> res.amplitudes.round(2).tolist(), res.components
    ([0.8, 0.6], ((0, 1),))
    """
    n, p_fail = int(num_qubits), float(p_fail)
    mappings = _counts_list(counts)
    layers = [[], _layer_pairs(n, 0), _layer_pairs(n, 1)]
    names = ["counts[0]", "counts[1]", "counts[2]"]
    if extra is None:
        extra = ()
    for k, item in enumerate(extra):
        try:
            pairs, bridge_counts = item
        except (TypeError, ValueError) as exc:
            raise ValueError(f"extra[{k}] must be a (pairs, counts) tuple, got {item!r}") from exc
        layers.append(_check_pairs(pairs, n, f"extra[{k}] pairs"))
        mappings.append(bridge_counts)
        names.append(f"extra[{k}] counts")

    events = n * len(mappings)
    probs, errors, shots, kept_fraction = [], [], [], []
    for mapping, name in zip(mappings, names, strict=True):
        unary, total = _unary_counts(mapping, n, name)
        kept = float(unary.sum()) if postselect else total
        if kept <= 0:
            raise ValueError(
                f"{name} has no Hamming-weight-1 outcome to post-select on ({total:g} shots)"
            )
        probs.append(unary / kept)
        errors.append(_sqrt_error(kept, events, p_fail))
        shots.append(_shots_value(total))
        kept_fraction.append(kept / total)

    magnitudes = np.sqrt(probs[0])
    t0 = errors[0]
    delta = SIGN_FACTOR * t0 if delta is None else float(delta)

    # significant edges, most significant first
    edges = []
    for c in range(1, len(mappings)):
        threshold = 2.0 * math.sqrt(2.0) * errors[c]
        for a, b in layers[c]:
            d_hat = math.sqrt(2.0 * probs[c][b]) - math.sqrt(2.0 * probs[c][a])
            if abs(d_hat) > threshold:
                edges.append((abs(d_hat) - threshold, a, b, int(d_hat < 0)))
    edges.sort(key=lambda e: -e[0])
    uf = _SignedUnionFind(n)
    for _, a, b, opposite in edges:
        uf.union(a, b, opposite)

    groups: dict[int, list[int]] = {}
    parity = np.zeros(n, dtype=int)
    for j in range(n):
        root, parity[j] = uf.find(j)
        groups.setdefault(root, []).append(j)
    signs = np.ones(n, dtype=int)
    for members in groups.values():
        lead = max(members, key=lambda j: (magnitudes[j], -j))
        for j in members:
            signs[j] = 1 if parity[j] == parity[lead] else -1

    reference_index = int(np.argmax(magnitudes))
    reference = groups[uf.find(reference_index)[0]]
    others = [m for m in groups.values() if m is not reference]
    outside = [j for m in others for j in m]
    error_estimate = t0 + 2.0 * float(max((magnitudes[j] for j in outside), default=0.0))
    error_estimate = max(error_estimate, t0)
    mattering = [m for m in others if t0 + 2.0 * max(magnitudes[j] for j in m) > delta]
    negligible = sorted(j for m in others if m not in mattering for j in m)
    components = (tuple(reference),) + tuple(tuple(m) for m in sorted(mattering))
    return TomographyResult(
        amplitudes=signs * magnitudes,
        magnitudes=magnitudes,
        signs=signs,
        shots=tuple(shots),
        kept_fraction=tuple(kept_fraction),
        error_estimate=float(error_estimate),
        components=components,
        negligible=tuple(negligible),
        magnitude_error=float(t0),
        delta=float(delta),
        p_fail=p_fail,
    )


@validates(result=Instance(TomographyResult))
def bridge_pairs(result: TomographyResult) -> list[list[tuple[int, int]]]:
    """Pairs for :func:`bridge_circuit` that join the sign components of a result.

    Components are chained in index order through their largest-magnitude members; links
    alternate between (at most) two circuits so that each circuit's pairs are disjoint.

    Parameters
    ----------
    result : TomographyResult

    Returns
    -------
    list of list of (int, int)
        Empty when the signs are resolved; otherwise one or two pair lists, one per bridge
        circuit.

    Examples
    --------
    >>> z = {"001": 2 * 10**6, "100": 2 * 10**6}  # y = (1, 0, +-1) / sqrt(2): a gap at 1
    >>> even = {"001": 10**6, "010": 10**6, "100": 2 * 10**6}
    >>> odd = {"001": 2 * 10**6, "010": 10**6, "100": 10**6}
    >>> res = reconstruct([z, even, odd], 3)
    >>> res.components, bridge_pairs(res)
    (((0,), (2,)), [[(0, 2)]])
    """
    if result.signs_resolved:
        return []
    ordered = sorted(result.components, key=min)
    leads = [max(m, key=lambda j: (result.magnitudes[j], -j)) for m in ordered]
    links = [(leads[k], leads[k + 1]) for k in range(len(leads) - 1)]
    circuits = [links[0::2], links[1::2]]
    return [c for c in circuits if c]
