"""A device's calibration pinned in a JSON file, so a paper can name the device it ran on.

:func:`save_snapshot` writes what a backend's ``Target`` holds: every instruction with the
qubits it acts on, its error and duration, and each qubit's T1, T2 and frequency (readout
errors are the ``measure`` instruction's errors). :func:`load_snapshot` rebuilds the ``Target``
and a :class:`SnapshotFileBackend` around it, and ``get_target(path)`` turns that into a
hardware target whose noisy simulator is ``AerSimulator.from_backend`` of the snapshot, with
``NoiseModel.from_backend`` of its calibration: the same numbers, file after file.

The format is versioned (:data:`SNAPSHOT_FORMAT`, :data:`SNAPSHOT_VERSION`); a file that is not
a snapshot, or one written by a newer format than this version reads, is refused with a
``ValueError`` that says which.
"""

from __future__ import annotations

import json
import math
import os
from datetime import datetime, timezone
from pathlib import Path

from qiskit.circuit import IfElseOp, SwitchCaseOp, WhileLoopOp
from qiskit.circuit.controlflow import BoxOp, BreakLoopOp, ContinueLoopOp, ForLoopOp
from qiskit.circuit.library import get_standard_gate_name_mapping
from qiskit.providers import BackendV2, Options, QubitProperties
from qiskit.transpiler import InstructionProperties, Target

from qdensity.hardware._snapshot_checks import MAX_SNAPSHOT_BYTES, check_snapshot_data, t2_bound
from qdensity.io import atomic_write_text
from qdensity.validation import FilePath, Instance, validates

__all__ = ["SNAPSHOT_FORMAT", "SNAPSHOT_VERSION", "SnapshotFileBackend", "save_snapshot",
           "load_snapshot", "is_snapshot_path"]

#: The ``format`` field of every snapshot file.
SNAPSHOT_FORMAT = "qdensity-device-snapshot"
#: The newest format version this release reads and the one it writes.
SNAPSHOT_VERSION = 1

_CONTROL_FLOW = {"if_else": IfElseOp, "while_loop": WhileLoopOp, "for_loop": ForLoopOp,
                 "switch_case": SwitchCaseOp, "break_loop": BreakLoopOp,
                 "continue_loop": ContinueLoopOp, "box": BoxOp}
_CONTROL_NAMES = frozenset(_CONTROL_FLOW)


def _arities() -> dict[str, int]:
    """Standard instruction name -> the number of qubits it acts on."""
    return {k: g.num_qubits for k, g in get_standard_gate_name_mapping().items()}


class SnapshotFileBackend(BackendV2):
    """A ``BackendV2`` holding a calibration read from a snapshot file (it runs nothing itself:
    simulate it with ``AerSimulator.from_backend(backend)``).

    Parameters
    ----------
    name : str
        The device's name as saved.
    target : qiskit.transpiler.Target

    Examples
    --------
    >>> from qiskit.providers.fake_provider import GenericBackendV2
    >>> backend = SnapshotFileBackend("my_device", GenericBackendV2(2, seed=1).target)
    >>> backend.name, backend.num_qubits
    ('my_device', 2)
    """

    def __init__(self, name: str, target: Target):
        super().__init__(name=name, description=f"calibration snapshot of {name}")
        self._target = target

    @property
    def target(self) -> Target:
        """The calibrated ``Target``."""
        return self._target

    @property
    def max_circuits(self) -> None:
        """No limit of its own."""
        return None

    @classmethod
    def _default_options(cls):
        return Options()

    def run(self, run_input, **options):
        """Simulate on ``AerSimulator.from_backend(self)`` (noisy, from the calibration)."""
        from qiskit_aer import AerSimulator

        return AerSimulator.from_backend(self).run(run_input, **options)


def _num(x):
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)


def _as_target(device) -> tuple[str, Target]:
    if isinstance(device, BackendV2):
        return device.name, device.target
    if isinstance(device, Target):
        return device.description or "target", device
    hw_target = getattr(device, "target", None)  # a HardwareTarget
    if isinstance(hw_target, Target) and isinstance(getattr(device, "name", None), str):
        return device.name, hw_target
    raise TypeError(f"device must be a BackendV2, a qiskit.transpiler.Target or a "
                    f"HardwareTarget with a Target, got {type(device).__name__}")


@validates(
    device=[Instance("qiskit.providers:BackendV2"), Instance("qiskit.transpiler:Target"),
            Instance("qdensity.hardware.targets:HardwareTarget")],
    path=FilePath(exists=None),
)
def save_snapshot(device, path: str | os.PathLike) -> Path:
    """Write a device's calibration (its ``Target``) to a JSON file.

    Parameters
    ----------
    device : qiskit.providers.BackendV2, qiskit.transpiler.Target or HardwareTarget
        A fake backend, a real ``IBMBackend``, a ``GenericBackendV2``, ...
    path : str or os.PathLike
        Where to write (``.json`` by convention; ``get_target`` recognises paths that end so).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        An instruction that is neither a standard gate, ``measure`` / ``reset`` / ``delay``
        nor control flow, or a calibration value :func:`load_snapshot` would refuse (an
        error outside ``[0, 1]``, T1 <= 0, a negative duration: it could not be read back).
        A T2 above ``2 * T1`` is written as ``2 * T1``, the value qiskit-aer's noise model
        uses; a device without qubit properties is written without them.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from qiskit.providers.fake_provider import GenericBackendV2
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "dev.json"
    >>> save_snapshot(GenericBackendV2(3, seed=1), path) == path
    True
    >>> load_snapshot(path).num_qubits
    3
    """
    name, target = _as_target(device)
    standard = get_standard_gate_name_mapping()
    instructions: dict[str, list | None] = {}
    for op_name in target.operation_names:
        if op_name not in standard and op_name not in _CONTROL_FLOW:
            raise ValueError(f"instruction {op_name!r} of device {name!r} cannot be saved "
                             f"(supported: standard gates, measure, reset, delay, control flow)")
        props = target[op_name]
        if None in props:  # a global instruction (control flow)
            instructions[op_name] = None
            continue
        instructions[op_name] = [
            {"qubits": list(qargs),
             "error": _num(getattr(p, "error", None)) if p is not None else None,
             "duration": _num(getattr(p, "duration", None)) if p is not None else None}
            for qargs, p in props.items()
        ]
    qubits = [None if q is None else {"t1": _num(q.t1), "t2": t2_bound(_num(q.t1), _num(q.t2)),
                                      "frequency": _num(q.frequency)}
              for q in (target.qubit_properties or [None] * target.num_qubits)]
    import qiskit

    data = {
        "format": SNAPSHOT_FORMAT, "version": SNAPSHOT_VERSION, "name": name,
        "num_qubits": target.num_qubits, "dt": _num(target.dt),
        "saved_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "qiskit": qiskit.__version__, "qubits": qubits, "instructions": instructions,
    }
    # what load_snapshot would refuse is not written (an error of 1.5, T1 <= 0, ...)
    check_snapshot_data(data, f"device {name!r} (not saved)", _arities(), _CONTROL_NAMES)
    out = Path(path)
    atomic_write_text(out, json.dumps(data, indent=1))
    return out


def is_snapshot_path(name) -> bool:
    """Whether ``name`` is a path to a snapshot file (a path object, or a str ending ``.json``).

    Parameters
    ----------
    name : object

    Returns
    -------
    bool

    Examples
    --------
    >>> is_snapshot_path("device.json"), is_snapshot_path("heavy_hex")
    (True, False)
    """
    return isinstance(name, os.PathLike) or (isinstance(name, str) and name.endswith(".json"))


def _refuse(path, why: str):
    raise ValueError(f"{os.fspath(path)!r} is not a qdensity device snapshot ({why}); write one "
                     f"with qdensity.hardware.snapshot_files.save_snapshot(backend, path)")


@validates(path=FilePath(exists="file"))
def load_snapshot(path: str | os.PathLike) -> SnapshotFileBackend:
    """The backend of a snapshot file written by :func:`save_snapshot`.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    SnapshotFileBackend
        Its ``target`` holds the saved instructions, errors, durations and qubit properties.

    Raises
    ------
    ValueError
        A missing file, a file that is not a snapshot (not UTF-8 JSON, over
        ``MAX_SNAPSHOT_BYTES``, nested too deep), one of a newer format version, or a field
        out of its range (:mod:`qdensity.hardware._snapshot_checks`: errors in ``[0, 1]``,
        T1 > 0, 0 < T2 <= 2 T1, durations >= 0, qubit indices in range, each gate on as many
        qubits as it acts on), named with the file, the field and the qubit; all before
        anything is built.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from qiskit.providers.fake_provider import GenericBackendV2
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "d.json"
    >>> _ = save_snapshot(GenericBackendV2(2, seed=1), path)
    >>> backend = load_snapshot(path)
    >>> isinstance(backend, SnapshotFileBackend), backend.num_qubits
    (True, 2)
    """
    p = Path(path)
    size = p.stat().st_size
    if size > MAX_SNAPSHOT_BYTES:
        _refuse(path, f"{size} bytes, more than the {MAX_SNAPSHOT_BYTES} a snapshot may take")
    try:
        data = json.loads(p.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        _refuse(path, f"not JSON: {exc}")
    except RecursionError:
        _refuse(path, "not JSON a snapshot can hold: nested deeper than Python's JSON reader "
                      "allows (a snapshot nests 5 deep)")
    if not isinstance(data, dict) or data.get("format") != SNAPSHOT_FORMAT:
        _refuse(path, f"no 'format': {SNAPSHOT_FORMAT!r} field")
    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        _refuse(path, f"bad version {version!r}")
    if version > SNAPSHOT_VERSION:
        raise ValueError(f"snapshot file {os.fspath(path)!r} has format version {version}, "
                         f"newer than this qdensity reads ({SNAPSHOT_VERSION}); upgrade qdensity")
    check_snapshot_data(data, f"snapshot file {os.fspath(path)!r}", _arities(), _CONTROL_NAMES)
    try:
        # qubits without properties get empty ones (unknown T1/T2), as qiskit-aer's
        # NoiseModel.from_backend reads a property object for every qubit
        saved = data.get("qubits") or [None] * data["num_qubits"]
        qubits = [QubitProperties(**(q or {})) for q in saved]
        target = Target(description=data["name"], num_qubits=data["num_qubits"],
                        dt=data.get("dt"), qubit_properties=qubits)
        standard = get_standard_gate_name_mapping()
        for op_name, entries in data["instructions"].items():
            if op_name in _CONTROL_FLOW:
                target.add_instruction(_CONTROL_FLOW[op_name], name=op_name)
                continue
            target.add_instruction(standard[op_name], {
                tuple(e["qubits"]): InstructionProperties(error=e.get("error"),
                                                          duration=e.get("duration"))
                for e in entries})
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        _refuse(path, f"malformed: {exc!r}")
    return SnapshotFileBackend(data["name"], target)
