"""Checks of a device calibration before anything is built from it.

A snapshot file (:mod:`qdensity.hardware.snapshot_files`) is read as untrusted input: every
field is checked for its type and range, and every error names the file, the field and the
qubit, before a ``Target`` or a noise model exists. qiskit-aer would otherwise take a readout
error of NaN (and sample as if there were none), a gate error of 1.5, or fail on T1 <= 0 only
when the noise model is first built, naming neither the file nor the qubit.

The ranges are the physical ones: errors are probabilities in ``[0, 1]``; T1 > 0; 0 < T2 <= 2 T1
(the bound of a qubit's relaxation; a calibration that reports a larger T2 is measuring noise,
and qiskit-aer's noise model truncates it to 2 T1, which is what :func:`save_snapshot` writes);
durations and ``dt`` finite and >= 0 (``dt`` > 0); frequencies finite and >= 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from qdensity.validation import MAX_CIRCUIT_QUBITS

__all__ = ["MAX_SNAPSHOT_BYTES", "check_snapshot_data", "t2_bound"]

#: Largest snapshot file read (a 4,096-qubit device with every pair coupled stays below it).
MAX_SNAPSHOT_BYTES = 256 * 2**20

_QUBIT_FIELDS = frozenset({"t1", "t2", "frequency"})
_ENTRY_FIELDS = frozenset({"qubits", "error", "duration"})


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def t2_bound(t1, t2):
    """``t2`` as qiskit-aer's noise model reads it: at most ``2 * t1`` (None stays None)."""
    if t1 is None or t2 is None or not (_number(t1) and _number(t2)):
        return t2
    return min(t2, 2 * t1)


class _Where:
    def __init__(self, source: str):
        self.source = source

    def fail(self, field: str, value, allowed: str, qubit=None) -> None:
        on = "" if qubit is None else f" (qubit {qubit})"
        raise ValueError(f"{self.source}: {field}{on} must be {allowed}, got {value!r}")

    def optional(self, field: str, value, low: float, high: float = math.inf, *,
                 open_low: bool = False, qubit=None) -> None:
        """``value`` is None or a finite number in the range."""
        if value is None:
            return
        allowed = (f"None or a finite number {'>' if open_low else '>='} {low:g}"
                   + ("" if high == math.inf else f" and <= {high:g}"))
        if not _number(value) or not math.isfinite(value):
            self.fail(field, value, allowed, qubit)
        if (value <= low if open_low else value < low) or value > high:
            self.fail(field, value, allowed, qubit)


def _check_qubits(where: _Where, qubits, n: int) -> None:
    if qubits is None:
        return
    if not isinstance(qubits, list) or len(qubits) not in (0, n):
        where.fail("qubits", type(qubits).__name__ if not isinstance(qubits, list)
                   else f"a list of {len(qubits)}", f"null or a list of {n} entries (one per "
                   f"qubit)")
    for q, props in enumerate(qubits):
        if props is None:
            continue
        if not isinstance(props, dict) or not set(props) <= _QUBIT_FIELDS:
            where.fail(f"qubits[{q}]", props, f"null or an object with fields "
                       f"{sorted(_QUBIT_FIELDS)}", q)
        t1, t2 = props.get("t1"), props.get("t2")
        where.optional(f"qubits[{q}].t1", t1, 0.0, open_low=True, qubit=q)
        where.optional(f"qubits[{q}].t2", t2, 0.0, open_low=True, qubit=q)
        if t1 is not None and t2 is not None and t2 > 2 * t1:
            where.fail(f"qubits[{q}].t2", t2, f"<= 2 * t1 = {2 * t1!r} (relaxation bounds "
                       f"dephasing)", q)
        where.optional(f"qubits[{q}].frequency", props.get("frequency"), 0.0, qubit=q)


def _check_entries(where: _Where, op_name: str, entries, n: int, arity: int) -> None:
    field = f"instructions.{op_name}"
    if not isinstance(entries, list):
        where.fail(field, type(entries).__name__, "a list of {qubits, error, duration} objects")
    if len(entries) > max(n, 1) ** arity:
        where.fail(field, f"{len(entries)} entries", f"at most {max(n, 1) ** arity} (one per "
                   f"tuple of {arity} of the {n} qubits)")
    seen: set[tuple] = set()
    for i, e in enumerate(entries):
        at = f"{field}[{i}]"
        if not isinstance(e, dict) or "qubits" not in e or not set(e) <= _ENTRY_FIELDS:
            where.fail(at, e, f"an object with fields {sorted(_ENTRY_FIELDS)} ('qubits' "
                       f"required)")
        qargs = e["qubits"]
        if (not isinstance(qargs, list) or len(qargs) != arity
                or any(isinstance(q, bool) or not isinstance(q, int) for q in qargs)):
            where.fail(f"{at}.qubits", qargs, f"a list of {arity} qubit indices ({op_name!r} "
                       f"acts on {arity} qubit{'s' if arity != 1 else ''})")
        bad = [q for q in qargs if not 0 <= q < n]
        if bad:
            where.fail(f"{at}.qubits", qargs, f"indices in [0, {n - 1}] (the device has {n} "
                       f"qubits)", bad[0])
        if len(set(qargs)) != len(qargs) or tuple(qargs) in seen:
            where.fail(f"{at}.qubits", qargs, "distinct qubits, each tuple listed once")
        seen.add(tuple(qargs))
        on = qargs[0] if arity == 1 else tuple(qargs)
        where.optional(f"{at}.error", e.get("error"), 0.0, 1.0, qubit=on)
        where.optional(f"{at}.duration", e.get("duration"), 0.0, qubit=on)


def check_snapshot_data(data, source: str, arities: Mapping[str, int],
                        control_flow: frozenset[str]) -> None:
    """Refuse a snapshot's fields that are of the wrong type or out of range.

    Parameters
    ----------
    data : object
        The parsed JSON (its ``format`` and ``version`` already checked).
    source : str
        Names the file in every message.
    arities : mapping
        Instruction name -> number of qubits it acts on (the instructions a snapshot may hold).
    control_flow : frozenset of str
        Global instructions (``null`` entries).

    Raises
    ------
    ValueError
        Naming ``source``, the field, the qubit where there is one, the value and what is
        allowed.
    """
    where = _Where(source)
    name, n = data.get("name"), data.get("num_qubits")
    if not isinstance(name, str) or not name:
        where.fail("name", name, "a non-empty str")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_CIRCUIT_QUBITS:
        where.fail("num_qubits", n, f"an int in [1, {MAX_CIRCUIT_QUBITS}]")
    where.optional("dt", data.get("dt"), 0.0, open_low=True)
    _check_qubits(where, data.get("qubits"), n)
    instructions = data.get("instructions")
    if not isinstance(instructions, dict):
        where.fail("instructions", type(instructions).__name__, "an object: instruction name "
                   "-> list of {qubits, error, duration}")
    for op_name, entries in instructions.items():
        if op_name in control_flow:
            if entries is not None:
                where.fail(f"instructions.{op_name}", entries, "null (a global instruction)")
            continue
        if op_name not in arities:
            where.fail("instructions", op_name, "standard gates, measure, reset, delay or "
                       "control flow")
        _check_entries(where, op_name, entries, n, arities[op_name])
