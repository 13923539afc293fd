"""Declared constraints for arrays, paths, circuits, observables, engines, targets, seeds,
callables and sequences (see :mod:`qdensity._constraints`)."""

from __future__ import annotations

import math
import numbers
import os
import re

import numpy as np

from qdensity._constraints._core import _NOT_A_FILE, Constraint, Instance

_DTYPES = {"real": "biuf", "int": "iu", "bool": "b", "complex": "biufc", "any": None}


class Array(Constraint):
    """An array-like of a given number of dimensions, shape, dtype kind and finiteness.

    Parameters
    ----------
    ndim : int or tuple of int, optional
        Allowed ``ndim`` values.
    shape : tuple, optional
        Required shape; ``None`` entries are free (checked only when ``ndim`` matches).
    dtype : {"real", "int", "bool", "complex", "any"}
        Allowed element kind (``"real"`` refuses complex values, ``"int"`` refuses floats).
    finite : bool
        Refuse NaN and inf.
    min_size : int
        Fewest elements.
    max_size : int, optional
        Most elements (an upper bound on what the callable will allocate from it).

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.validation import Array
    >>> c = Array(ndim=2, shape=(None, 3))
    >>> c.is_satisfied_by(np.zeros((5, 3))), c.is_satisfied_by(np.zeros((5, 4)))
    (True, False)
    >>> c.is_satisfied_by([[1.0, 2.0, np.nan]])  # finite by default
    False
    """

    def __init__(self, ndim=None, shape=None, *, dtype: str = "real", finite: bool = True,
                 min_size: int = 1, max_size: int | None = None):
        self.ndim = (ndim,) if isinstance(ndim, int) else ndim
        self.shape, self.dtype, self.finite = shape, dtype, finite
        self.min_size, self.max_size = min_size, max_size
        if shape is not None and self.ndim is None:
            self.ndim = (len(shape),)

    @staticmethod
    def _as_array(value):
        if isinstance(value, np.ndarray):
            return value
        if isinstance(value, (str, bytes, dict, set)) or value is None:
            return None
        if not isinstance(value, (list, tuple, numbers.Number)) and not hasattr(value,
                                                                                "__array__"):
            return None
        try:
            arr = np.asarray(value)
        except (ValueError, TypeError):  # ragged
            return None
        return arr

    def type_ok(self, value) -> bool:
        arr = self._as_array(value)
        if arr is None:
            return False
        kinds = _DTYPES[self.dtype]
        return kinds is None or arr.dtype.kind in kinds

    def reason(self, value) -> str:
        arr = self._as_array(value)
        if arr is None:
            return ""
        if self.ndim is not None and arr.ndim not in self.ndim:
            return f"it has {arr.ndim} dimensions, shape {arr.shape}"
        if self.shape is not None and any(s is not None and s != a for s, a in
                                          zip(self.shape, arr.shape, strict=False)):
            return f"it has shape {arr.shape}"
        if arr.size < self.min_size or (self.max_size is not None and arr.size > self.max_size):
            return f"it has length {arr.size}" if arr.ndim == 1 else f"it has shape {arr.shape}"
        if arr.dtype.kind not in (_DTYPES[self.dtype] or arr.dtype.kind):
            return f"its dtype is {arr.dtype}"
        return "it holds NaN or inf"

    def is_satisfied_by(self, value) -> bool:
        arr = self._as_array(value)
        kinds = _DTYPES[self.dtype]
        if arr is None or (kinds is not None and arr.dtype.kind not in kinds):
            return False
        if self.ndim is not None and arr.ndim not in self.ndim:
            return False
        if self.shape is not None and any(s is not None and s != a
                                          for s, a in zip(self.shape, arr.shape, strict=False)):
            return False
        if arr.size < self.min_size or (self.max_size is not None and arr.size > self.max_size):
            return False
        if self.finite and arr.dtype.kind in "fc":
            return bool(np.isfinite(arr).all())  # isfinite never warns
        return True

    def __str__(self) -> str:
        kind = {"real": "real", "int": "integer", "bool": "boolean", "complex": "numeric",
                "any": ""}[self.dtype]
        dims = ""
        if self.ndim is not None:
            dims = " or ".join(f"{d}-dimensional" for d in self.ndim) + " "
        out = f"a {dims}{'finite ' if self.finite else ''}{kind} array".replace("  ", " ")
        if self.shape is not None:
            out += " of shape (" + ", ".join("any" if s is None else str(s)
                                             for s in self.shape) + ")"
        size = "length" if self.ndim == (1,) else "size"
        limits = ([f"{size} >= {self.min_size}"] if self.min_size > 0 else []) + (
            [f"<= {self.max_size}" if self.min_size > 0 else f"{size} <= {self.max_size}"]
            if self.max_size is not None else [])
        return out + (" of " + " and ".join(limits) if limits else "")

    def example(self) -> np.ndarray | int | float | bool:
        ndim = self.ndim[0] if self.ndim else 1
        shape = [2] * ndim
        if self.shape is not None:
            shape = [2 if s is None else s for s in self.shape]
        dtype = {"int": int, "bool": bool}.get(self.dtype, float)
        return np.ones(shape, dtype=dtype) if ndim else dtype(1)

    def violations(self) -> list:
        good = np.asarray(self.example())
        out = ["bogus", None, object(), {"a": 1}]
        if good.ndim >= 1:
            bad = good.astype(float)
            bad.flat[0] = math.nan
            out.append(bad)
            bad = good.astype(float)
            bad.flat[-1] = math.inf
            out.append(bad)
            out.append(good.astype(complex) + 1j)
            out.append(good.astype(complex))  # complex with zero imaginary parts: still complex
            out.append(np.zeros((0,) * good.ndim))
            out.append(good.reshape(-1)[:1].reshape((1,) * (good.ndim + 1)))
            out.append(good.astype(float) + 0.5)
        out.append(np.float64(math.nan))
        return [v for v in out if not self.is_satisfied_by(v)]


class FilePath(Constraint):
    """A path (``str`` or ``os.PathLike``); with ``exists="file"`` an existing file, with
    ``"dir"`` an existing folder, with None any path.

    Examples
    --------
    >>> from qdensity.validation import FilePath
    >>> FilePath().is_satisfied_by("/no/such/file"), FilePath(None).is_satisfied_by("out.json")
    (False, True)
    """

    def __init__(self, exists: str | None = "file"):
        self.exists = exists

    def type_ok(self, value) -> bool:
        return isinstance(value, (str, os.PathLike)) and not isinstance(value, bytes)

    def is_satisfied_by(self, value) -> bool:
        if not self.type_ok(value) or not os.fspath(value):
            return False
        if self.exists == "file":  # a regular file: not a device, FIFO or socket
            return os.path.isfile(value)
        if self.exists == "dir":
            return os.path.isdir(value)
        return "\0" not in os.fspath(value)

    def reason(self, value) -> str:
        if self.exists == "file" and self.type_ok(value) and os.fspath(value):
            import stat

            try:
                mode = os.stat(value).st_mode
            except (OSError, ValueError):
                return ""
            for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"),
                               (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO"),
                               (stat.S_ISSOCK, "a socket")):
                if test(mode):
                    return f"it is {what}, not a regular file"
        return ""

    def __str__(self) -> str:
        return {"file": "the path of an existing file (a regular file)",
                "dir": "the path of an existing folder", None: "a file path"}[self.exists]

    def example(self) -> str:
        return {"file": __file__, "dir": os.path.dirname(__file__),
                None: os.path.join(os.path.dirname(__file__), "x")}[self.exists]

    def violations(self) -> list:
        out = [3, None, b"x", object(), "", "a\0b"]
        if self.exists:
            out += [_NOT_A_FILE, os.path.dirname(__file__) if self.exists == "file" else __file__]
        if self.exists == "file":  # special files read forever (/dev/zero) or block (a FIFO)
            out += [p for p in ("/dev/zero", "/dev/urandom", os.devnull) if os.path.exists(p)]
        return [v for v in out if not self.is_satisfied_by(v)]


class FileName(Constraint):
    """A name that becomes part of a file name (a result's, a figure's, a checkpoint's): letters,
    digits, ``_``, ``-`` and ``.``, not starting with ``.`` and at most ``max_len`` characters.
    Never a path: no separator, no ``..``, no NUL, so a name read from a file cannot write
    outside the folder it is joined to.

    Examples
    --------
    >>> from qdensity.validation import FileName
    >>> FileName().is_satisfied_by("run-1_seed0"), FileName().is_satisfied_by("../escape")
    (True, False)
    """

    _PATTERN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")

    def __init__(self, max_len: int = 200):
        self.max_len = max_len

    def type_ok(self, value) -> bool:
        return isinstance(value, str)

    def is_satisfied_by(self, value) -> bool:
        return (isinstance(value, str) and 0 < len(value) <= self.max_len
                and self._PATTERN.fullmatch(value) is not None and ".." not in value)

    def reason(self, value) -> str:
        if isinstance(value, str) and ("/" in value or "\\" in value or ".." in value):
            return "a name is never a path"
        return ""

    def __str__(self) -> str:
        return (f"a file name of 1 to {self.max_len} letters, digits, '_', '-' or '.' (not "
                f"starting with '.', no '..')")

    def example(self):
        return "pyramid-shots"

    def violations(self) -> list:
        return ["", "../x", "a/b", "/etc/passwd", "..", ".hidden", "a\0b", "a\\b", "x" * 201, 3,
                None, b"x"]


class Circuit(Instance):
    """A ``QuantumCircuit`` of at most ``max_qubits`` qubits (and at least ``min_qubits``).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.validation import Circuit
    >>> c = Circuit(min_qubits=2)
    >>> c.is_satisfied_by(QuantumCircuit(2)), c.is_satisfied_by(QuantumCircuit(1))
    (True, False)
    """

    def __init__(self, min_qubits: int = 0, max_qubits: int | None = None):
        from qiskit.circuit import QuantumCircuit

        super().__init__(QuantumCircuit, "qiskit QuantumCircuit")
        self.min_qubits, self.max_qubits = min_qubits, max_qubits

    def example(self):
        # a method, not a lambda kept on the object: a declaration pickles and deep-copies
        from qiskit.circuit import QuantumCircuit

        return QuantumCircuit(max(self.min_qubits, 2))

    def is_satisfied_by(self, value) -> bool:
        if not super().is_satisfied_by(value):
            return False
        n = value.num_qubits
        return n >= self.min_qubits and (self.max_qubits is None or n <= self.max_qubits)

    def __str__(self) -> str:
        limits = ([f">= {self.min_qubits}"] if self.min_qubits else []) + (
            [f"<= {self.max_qubits}"] if self.max_qubits is not None else [])
        return "a qiskit QuantumCircuit" + (f" of {' and '.join(limits)} qubits" if limits
                                            else "")

    def reason(self, value) -> str:
        return f"it has {value.num_qubits} qubits" if self.type_ok(value) else ""

    def violations(self) -> list:
        from qiskit.circuit import QuantumCircuit

        out = super().violations() + [QuantumCircuit(max(self.min_qubits - 1, 0))]
        return [v for v in out if not self.is_satisfied_by(v)]


class Observable(Constraint):
    """An observable: a ``SparsePauliOp``, ``Pauli`` or Pauli label string (checked as a label,
    ``I X Y Z`` only; widths against the circuit are checked in the body).

    Examples
    --------
    >>> from qdensity.validation import Observable
    >>> Observable().is_satisfied_by("ZZI"), Observable().is_satisfied_by("ZQ")
    (True, False)
    """

    def type_ok(self, value) -> bool:
        from qiskit.quantum_info import Pauli, SparsePauliOp

        return isinstance(value, (str, Pauli, SparsePauliOp))

    def is_satisfied_by(self, value) -> bool:
        if not self.type_ok(value):
            return False
        return not isinstance(value, str) or (bool(value) and set(value) <= set("IXYZ"))

    def __str__(self) -> str:
        return "a SparsePauliOp, a Pauli or a Pauli label such as 'ZI'"

    def example(self) -> str:
        return "ZZ"

    def violations(self) -> list:
        return [3, None, object(), "", "ZQ", math.nan, ["Z"]]


class _ExampleEngine:
    """The smallest value :class:`EngineLike` accepts (its ``run`` answers nothing)."""

    def run(self, jobs):
        raise NotImplementedError("an example engine for the declarations' tests")


class EngineLike(Constraint):
    """An engine: anything with ``run(jobs)`` (ExactEngine, SamplerEngine, AdjointEngine).

    Examples
    --------
    >>> from qdensity.execution import ExactEngine
    >>> from qdensity.validation import EngineLike
    >>> EngineLike().is_satisfied_by(ExactEngine()), EngineLike().is_satisfied_by("exact")
    (True, False)
    """

    def is_satisfied_by(self, value) -> bool:
        return callable(getattr(value, "run", None)) and not isinstance(value, type)

    def __str__(self) -> str:
        return "an engine with run(jobs) (ExactEngine, SamplerEngine, AdjointEngine)"

    def example(self) -> object:
        return _ExampleEngine()

    def violations(self) -> list:
        return ["exact", 3, object(), math.nan, [], type("E", (), {"run": lambda s, j: j})]


class TargetLike(Constraint):
    """A target as :func:`qdensity.hardware.targets.get_target` takes it: a ``HardwareTarget``,
    a target name or snapshot path, a ``BackendV2`` or a ``qiskit.transpiler.Target``.

    Examples
    --------
    >>> from qdensity.validation import TargetLike
    >>> TargetLike().is_satisfied_by("heavy_hex"), TargetLike().is_satisfied_by(3)
    (True, False)
    """

    def is_satisfied_by(self, value) -> bool:
        if isinstance(value, (str, os.PathLike)):
            return bool(os.fspath(value))
        if all(callable(getattr(value, a, None)) for a in ("simulator", "transpile")):
            return True
        from qiskit.providers import BackendV2
        from qiskit.transpiler import Target

        return isinstance(value, (BackendV2, Target))

    def type_ok(self, value) -> bool:
        return isinstance(value, (str, os.PathLike)) or self.is_satisfied_by(value)

    def __str__(self) -> str:
        return ("a HardwareTarget, a target name or snapshot path, a BackendV2 or a "
                "qiskit.transpiler.Target (qdensity.hardware.targets.get_target)")

    def example(self) -> str:
        return "all_to_all"

    def violations(self) -> list:
        return [3, object(), math.nan, [], ""]


