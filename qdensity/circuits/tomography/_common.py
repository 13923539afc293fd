"""Shared helpers of unary l-infinity tomography (Supp. F): layers, pair and bound checks.

The even/odd ``RBS(pi/4)`` layers and the check of bridge pairs serve both the circuit
builders and the reconstruction; the ``delta``/``p_fail`` checks and the square-root
concentration radius ``t`` serve both the shot bound and the reconstruction.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable

_REGISTER = "meas"


def _layer_pairs(num_qubits: int, start: int) -> list[tuple[int, int]]:
    return [(j, j + 1) for j in range(start, num_qubits - 1, 2)]


def _check_pairs(pairs, num_qubits: int, name: str = "pairs") -> list[tuple[int, int]]:
    if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Iterable):
        raise TypeError(f"{name} must be a sequence of (int, int) qubit pairs, got {pairs!r}")
    out: list[tuple[int, int]] = []
    used: set[int] = set()
    for pair in pairs:
        try:
            a, b = pair
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} entries must be (int, int) pairs, got {pair!r}") from exc
        for q in (a, b):
            if isinstance(q, bool) or not isinstance(q, numbers.Integral):
                raise TypeError(f"{name} entries must be int qubit indices, got {pair!r}")
            if not 0 <= int(q) < num_qubits:
                raise ValueError(
                    f"{name} entry {pair!r} is out of range for {num_qubits} qubits "
                    f"(allowed 0 .. {num_qubits - 1})"
                )
        if a == b:
            raise ValueError(f"{name} entry {pair!r} pairs a qubit with itself")
        if a in used or b in used:
            raise ValueError(
                f"{name} must be disjoint (each qubit in at most one pair, so the RBS(pi/4) "
                f"gates act in parallel), got {list(pairs)!r}"
            )
        used.update((int(a), int(b)))
        out.append((int(a), int(b)))
    if not out:
        raise ValueError(f"{name} must contain at least one pair")
    return out


def _sqrt_error(shots: float, events: int, p_fail: float) -> float:
    """``t`` with ``P(|sqrt(p_hat) - sqrt(p)| >= t) <= p_fail / events``: see shots_for_error."""
    return math.sqrt(math.log(2.0 * events / p_fail) / shots)
