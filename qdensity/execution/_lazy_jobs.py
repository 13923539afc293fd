"""Jobs whose circuits are built when read, with the compact program the Hamming-weight sampler
runs instead of the circuit.

A density gradient at device widths is thousands of templates that each differ from the
model's own circuits only by a layer and the measurements: ``n = 1024`` would hold 2,046
measured circuits of about 3,000 instructions each (6.3 million Qiskit instructions, several
GB). A :class:`LazyCircuitJob` holds how to build its circuit, not the circuit: reading
``job.circuit`` builds a ``QuantumCircuit`` (kept only while something else holds it), and
what a weight-1 template of RBS / FBS gates needs for sampling is held as a
:class:`UnaryProgram`: its Givens rotations as ``O(gates)`` integer and float arrays, the
exact gate list :func:`~qdensity.execution.samplers._hamming_compile.compile_template` would
read off the circuit, so the same rows and seed draw the same shots.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.execution.plans import CircuitJob, checked_rows
from qdensity.execution.samplers._hamming_compile import CompiledPrefix, compile_template

if TYPE_CHECKING:
    from qdensity.execution.unary import UnaryCircuit

__all__ = ["LazyCircuitJob", "SharedRows", "UnaryProgram", "unary_programs"]


@dataclass(frozen=True)
class UnaryProgram:
    """A measured weight-1 template of RBS / FBS gates, compiled: what the Hamming-weight
    sampler needs of it (and nothing of the circuit).

    Attributes
    ----------
    unary : UnaryCircuit
        The Givens rotations in circuit order. Their parameter indices are columns of the
        circuit's rows (``circuit.parameters`` order); ``unary.parameters`` are stand-ins, one
        ``ParameterVector`` shared by every program with as many parameters (the circuit's own
        would be ``P`` Python objects a program: 1.6 million over a plan at ``n = 1024``).
    occupied : int
        The qubit the input's X gate sets (the weight-1 input ``e_occupied``).
    name : str
        The circuit's name.

    Every qubit ``j`` is measured into clbit ``j`` (the plans' convention).
    """

    unary: UnaryCircuit
    occupied: int
    name: str = ""

    @property
    def num_qubits(self) -> int:
        """``n``: qubits, clbits and unary amplitudes."""
        return self.unary.num_qubits


def unary_programs(circuit: QuantumCircuit, pairs: Sequence[tuple[int, int]],
                   prefix: CompiledPrefix | None = None
                   ) -> tuple[UnaryProgram, UnaryProgram] | None:
    """The programs of ``circuit`` followed by an ``RBS(pi/4)`` layer on ``pairs`` and of
    ``circuit`` alone, both measured (qubit ``j`` into clbit ``j``), or None when ``circuit``
    is not a weight-1 template of RBS / FBS gates with angles linear in one parameter.

    The second program's arrays are views of the first's (its gates are a prefix).

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured: X on one qubit of ``|0...0>``, then RBS / FBS gates.
    pairs : sequence of (int, int)
        The layer's qubit pairs, in order.
    prefix : CompiledPrefix, optional
        The walk of ``circuit``'s first instructions (a shared loader ``V(x)``), done once
        for every circuit that begins with them (see
        :class:`~qdensity.execution.samplers._hamming_compile.CompiledPrefix`).

    Returns
    -------
    (UnaryProgram, UnaryProgram) or None
    """
    from qdensity.execution.unary import UnaryCircuit  # the compiled kernels, on first use
    from qdensity.execution.unary._layers import check_gate_list

    template = compile_template(circuit, prefix=prefix)
    if not template.unary or template.flipped:
        return None
    gates = template.gates
    g = len(gates)
    size = g + len(pairs)
    first = np.empty(size, dtype=np.int64)
    second = np.empty(size, dtype=np.int64)
    index = np.full(size, -1, dtype=np.int64)
    coefficient = np.zeros(size)
    offset = np.full(size, np.pi / 4)  # the layer's fixed angle
    for i, gate in enumerate(gates):  # as hamming._Compiled reads a compiled template
        angle = gate.angles[0]
        first[i], second[i] = gate.qubits[0], gate.qubits[-1]
        index[i] = angle.index if angle.kind == "linear" else -1
        coefficient[i], offset[i] = angle.coefficient, angle.offset
    if pairs:
        first[g:], second[g:] = np.asarray(pairs, dtype=np.int64).T
    n, params, occupied = template.num_qubits, template.parameters, template.occupied[0]

    # the gate list's checks once (numpy, cheap); the programs then skip UnaryCircuit's
    # per-Parameter checks of the shared stand-ins (about 15 ms a program at n = 1024)
    n, _, _, index, coefficient, offset, _ = check_gate_list(
        n, np.stack([first, second], axis=1), index, coefficient, offset, len(params))
    stand_ins = _stand_ins(len(params))

    def program(stop: int) -> UnaryProgram:
        unary = UnaryCircuit._from_checked(n, stand_ins, first[:stop], second[:stop],
                                           index[:stop], coefficient[:stop], offset[:stop])
        return UnaryProgram(unary, occupied, circuit.name)

    return program(size), program(g)


@lru_cache(maxsize=64)
def _stand_ins(count: int) -> tuple:
    """``count`` parameters that stand for a circuit's columns (shared, never bound): one
    tuple held by every program with as many parameters."""
    return tuple(ParameterVector("column", count))


class SharedRows:
    """Parameter rows ``(B, P)`` held as a block shared by many jobs and a block of their own.

    The rows of a density gradient's ``V(x) U_k`` are the loader's ``L`` columns (the same
    for every ``k``) and ``U_k``'s own: at ``n = 1024`` (16 rows) the loader is 1,023 of each
    job's 1,535 columns, 134 MB of the 201 MB the plan's rows would take. Here every job holds
    the loader's block once (the same array) and its own columns; :meth:`full` places both,
    the array a plain job would hold.

    Parameters
    ----------
    shared : numpy.ndarray, shape (B, L)
        Columns shared with other jobs (held, not copied: never write to it).
    shared_at : array_like of int, shape (L,)
        Where they go: column ``shared_at[j]`` of a row is ``shared[:, j]``.
    own : numpy.ndarray, shape (B, P - L)
        The remaining columns, in ascending column order.

    Examples
    --------
    >>> import numpy as np
    >>> rows = SharedRows(np.array([[1.0, 2.0]]), [2, 0], np.array([[9.0]]))
    >>> rows.full().tolist(), rows.shape
    ([[2.0, 9.0, 1.0]], (1, 3))
    """

    __slots__ = ("shared", "shared_at", "own", "own_at")

    def __init__(self, shared: np.ndarray, shared_at, own: np.ndarray) -> None:
        shared, own = np.asarray(shared, dtype=float), np.asarray(own, dtype=float)
        if shared.ndim != 2 or own.ndim != 2 or shared.shape[0] != own.shape[0]:
            raise ValueError(f"shared and own must be (B, L) and (B, P - L) blocks, got "
                             f"{shared.shape} and {own.shape}")
        at = np.asarray(shared_at, dtype=np.intp)
        P = shared.shape[1] + own.shape[1]
        if at.shape != (shared.shape[1],) or (at.size and (at.min() < 0 or at.max() >= P)):
            raise ValueError(f"shared_at must be {shared.shape[1]} columns in [0, {P})")
        placed = np.zeros(P, dtype=bool)
        placed[at] = True
        if int(placed.sum()) != at.size:
            raise ValueError("shared_at repeats a column")
        self.shared, self.shared_at, self.own = shared, at, own
        self.own_at = np.flatnonzero(~placed)

    @classmethod
    def split(cls, rows: np.ndarray, shared: np.ndarray, shared_at) -> SharedRows | None:
        """``rows`` as ``shared`` (placed at ``shared_at``) and its other columns, or None
        when ``rows[:, shared_at]`` is not exactly ``shared`` (then keep ``rows``)."""
        rows = np.asarray(rows, dtype=float)
        at = np.asarray(shared_at, dtype=np.intp)
        if rows.ndim != 2 or rows.shape[0] != np.shape(shared)[0] or not np.array_equal(
                rows[:, at], shared):
            return None
        out = cls(shared, at, np.empty((rows.shape[0], rows.shape[1] - at.size)))
        out.own[:] = rows[:, out.own_at]
        return out

    @property
    def shape(self) -> tuple[int, int]:
        """``(B, P)``: the rows :meth:`full` gives."""
        return (self.own.shape[0], self.shared.shape[1] + self.own.shape[1])

    def full(self) -> np.ndarray:
        """The ``(B, P)`` rows (a new array on each call)."""
        out = np.empty(self.shape)
        out[:, self.shared_at] = self.shared
        out[:, self.own_at] = self.own
        return out

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self.full()
        return out if dtype is None else out.astype(dtype, copy=False)

    def __getstate__(self) -> tuple:
        return (self.shared, self.shared_at, self.own)

    def __setstate__(self, state: tuple) -> None:
        self.__init__(*state)  # type: ignore[misc]


class LazyCircuitJob(CircuitJob):
    """A :class:`~qdensity.execution.plans.CircuitJob` whose circuit is built when read.

    ``job.circuit`` is a ``QuantumCircuit`` as for any job (the same object while something
    else holds it, else built again); the job itself holds only ``build``, its rows and, for
    the Hamming-weight sampler, an optional :class:`UnaryProgram` (``program``) that
    :class:`~qdensity.execution.sampler.SamplerEngine` samples without building the circuit.

    Parameters
    ----------
    build : callable
        ``build() -> QuantumCircuit``: the measured template (qubit ``j`` -> clbit ``j``).
    num_qubits, num_parameters : int
        The template's width and ``circuit.num_parameters``.
    values : array_like, shape (rows, P), or SharedRows
        The rows; a :class:`SharedRows` is kept as it is (``job.values`` places its blocks
        into a new array on each read; the Hamming-weight sampler reads its blocks through
        :attr:`held_rows`).
    shots : int, optional
    label : str
    program : UnaryProgram, optional
    """

    _build: Callable[[], QuantumCircuit]
    _num_qubits: int
    _num_parameters: int
    _rows: np.ndarray | SharedRows
    program: UnaryProgram | None

    def __init__(self, build: Callable[[], QuantumCircuit], num_qubits: int,
                 num_parameters: int, values, shots: int | None = None, label: str = "",
                 program: UnaryProgram | None = None) -> None:
        if not callable(build):
            raise TypeError(f"build must be a callable () -> QuantumCircuit, got "
                            f"{type(build).__name__}")
        if not isinstance(label, str):
            raise TypeError(f"label must be a str, got {type(label).__name__}")
        state = {"_build": build, "_num_qubits": int(num_qubits), "_held": None,
                 "_num_parameters": int(num_parameters), "_rows": values, "shots": shots,
                 "label": label, "program": program}
        for name, value in state.items():
            object.__setattr__(self, name, value)
        self._check_rows(int(num_parameters))

    def _check_rows(self, num_parameters: int) -> None:
        """:class:`~qdensity.execution.plans.CircuitJob`'s checks of the rows (a
        :class:`SharedRows`' placed once, then kept in blocks)."""
        rows = self.__dict__["_rows"]
        vals = checked_rows(rows.full() if isinstance(rows, SharedRows) else rows,
                            num_parameters, self.shots)
        if not isinstance(rows, SharedRows):
            object.__setattr__(self, "_rows", vals)

    @property
    def values(self) -> np.ndarray:
        """The ``(rows, P)`` parameter rows (of a :class:`SharedRows`: placed on each read)."""
        rows = self.__dict__["_rows"]
        return rows.full() if isinstance(rows, SharedRows) else rows

    @property
    def held_rows(self) -> np.ndarray | SharedRows:
        """The rows as held: an array, or the :class:`SharedRows` given."""
        return self.__dict__["_rows"]

    @property
    def rows(self) -> int:
        """Number of parameter rows (circuit executions)."""
        return int(self.__dict__["_rows"].shape[0])

    @property
    def circuit(self) -> QuantumCircuit:
        """The measured template, built on read (held by the job only weakly)."""
        held = self.__dict__["_held"]
        circuit = held() if held is not None else None
        if circuit is None:
            circuit = self._build()
            object.__setattr__(self, "_held", weakref.ref(circuit))
        return circuit

    @property
    def num_qubits(self) -> int:
        """Width of the template, without building it."""
        return self._num_qubits

    def with_shots(self, shots: int | None) -> LazyCircuitJob:
        """The same job with ``shots`` per row (still built on read)."""
        return LazyCircuitJob(self._build, self._num_qubits, self._num_parameters,
                              self.held_rows, shots, self.label, self.program)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_held"] = None  # a weak reference does not pickle
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
