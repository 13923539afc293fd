"""Gate-name sets of the hardware targets in :mod:`qdensity.hardware.targets`.

The instructions that are not gates (measure, reset, delay, barrier), the basis of the
``ideal`` target (every standard gate Aer simulates natively) and the checks of a user's
``basis_gates`` and ``optimization_level`` for ``get_target``.
"""

from __future__ import annotations

import functools
import numbers

from qiskit.circuit.library import get_standard_gate_name_mapping
from qiskit_aer import AerSimulator

_NON_GATES = frozenset({"measure", "reset", "delay", "barrier"})


@functools.cache
def _ideal_basis() -> tuple[str, ...]:
    """Standard gates that AerSimulator simulates natively."""
    aer = set(AerSimulator().configuration().basis_gates)
    mapping = get_standard_gate_name_mapping()
    return tuple(sorted(g for g in mapping if g in aer and g not in _NON_GATES))


def _check_basis(basis_gates) -> tuple[str, ...] | None:
    """``basis_gates`` as :func:`get_target` declared it (None or a list or tuple of 1 to 64
    str; its only caller), each name checked to be a standard gate."""
    if basis_gates is None:
        return None
    mapping = get_standard_gate_name_mapping()
    names = tuple(basis_gates)
    for g in names:
        if not isinstance(g, str) or g not in mapping or g in _NON_GATES:
            raise ValueError(
                f"basis_gates entry {g!r} is not a standard gate name; allowed: "
                f"{sorted(set(mapping) - _NON_GATES - {'global_phase'})}"
            )
    return names


def _check_level(level) -> int:
    if (isinstance(level, bool) or not isinstance(level, numbers.Integral)
            or not 0 <= int(level) <= 3):
        raise ValueError(f"optimization_level must be an int in 0..3, got {level!r}")
    return int(level)
