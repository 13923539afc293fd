"""Read a Hamming-weight-preserving template once: its input, its gates, its measurements.

:func:`compile_template` walks a circuit's instructions (composite gates through their
definitions) and returns a :class:`HammingTemplate`: the qubits that X gates set on
``|0...0>`` (the weight-``k`` input), the list of weight-preserving gates with their angles as
columns of the parameter array (:class:`Angle`), the qubit each clbit measures, and the clbits
read through a final bit flip (a relabelling). Anything else is refused with an
:class:`UnsupportedInstructionError` (a ``QiskitError`` and a ``ValueError``) naming the first
offending instruction and the alternative (qiskit-aer's sampler).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import NoReturn

import numpy as np
from qiskit.circuit import Parameter, ParameterExpression, QuantumCircuit
from qiskit.exceptions import QiskitError
from qiskit.quantum_info import Operator

from qdensity.analysis.gate_registry import FBS, GATES, GIVENS_GATES


class UnsupportedInstructionError(QiskitError, ValueError):
    """An instruction the Hamming-weight sampler cannot sample: a ``QiskitError`` (what
    qiskit's own samplers raise for an instruction they cannot run) and a ``ValueError``
    (qdensity's bad-input error).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.execution.samplers import HammingWeightSampler
    >>> from qdensity.execution.samplers.hamming import UnsupportedInstructionError
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.h(0)  # a superposition of Hamming weights 0 and 1
    >>> qc.measure_all()
    >>> try:
    ...     HammingWeightSampler(seed=1).run([qc])
    ... except UnsupportedInstructionError as err:
    ...     print(isinstance(err, ValueError), "does not preserve Hamming weight" in str(err))
    True True
    """

    def __str__(self) -> str:  # the message itself (QiskitError shows its repr)
        return str(self.message)


#: Gates with a vectorised block (angles evaluated for all rows at once) or a constant matrix,
#: read off the gate registry: weight-preserving entries with a ``block``, FBS (its own
#: tables) and the fixed gates.
KNOWN_GATES = frozenset(name for name, kind in GATES.items() if kind.preserves_hamming_weight
                        and (kind.block is not None or kind.fixed or kind is FBS))
_SKIPPED = frozenset({"barrier", "delay", "id"})
_FLIPS = frozenset({"x", "y"})
#: Widest gate judged by its matrix (``4 ** m`` entries).
MATRIX_MAX_QUBITS = 8
_TOL = 1e-10

_ALTERNATIVE = ("sample it with qiskit-aer instead (SamplerEngine(hamming_weight='never') "
                "or qiskit_aer.primitives.SamplerV2)")


@dataclass(frozen=True, slots=True)
class Angle:
    """One gate angle as a function of a parameter row.

    ``kind`` is ``"const"`` (``offset``), ``"linear"`` (``coefficient * values[:, index] +
    offset``) or ``"expr"`` (any other expression, bound row by row).
    """

    kind: str
    offset: float = 0.0
    index: int = -1
    coefficient: float = 0.0
    expr: ParameterExpression | None = None
    indices: tuple = ()

    def evaluate(self, values: np.ndarray) -> np.ndarray:
        """Angles for parameter rows ``values`` of shape (B, P): shape (B,) (or (1,) if fixed)."""
        if self.kind == "const":
            return np.full(1, self.offset)
        if self.kind == "linear":
            return self.coefficient * values[:, self.index] + self.offset
        assert self.expr is not None  # kind "expr"
        params = list(self.expr.parameters)
        out = np.empty(values.shape[0])
        for r in range(values.shape[0]):  # only angles not linear in one parameter
            bound = self.expr.bind({p: float(values[r, i]) for p, i in
                                    zip(params, self.indices, strict=True)})
            out[r] = float(bound)
        return out


@dataclass(slots=True)
class GateOp:
    """One weight-preserving gate: ``name``, circuit ``qubits`` (gate order), its angles, or a
    fixed local matrix (``matrix``, little-endian on ``qubits``), or a parameterised gate
    bound row by row (``operation``)."""

    name: str
    qubits: tuple
    angles: tuple = ()
    matrix: np.ndarray | None = None
    operation: tuple[QuantumCircuit, list[int]] | None = None
    position: int = 0

    @property
    def real(self) -> bool:
        """Whether the gate's block is real for every angle."""
        if getattr(GATES.get(self.name), "real", False):
            return True
        if self.matrix is not None:
            return bool(np.all(np.abs(self.matrix.imag) < _TOL))
        return False


@dataclass
class HammingTemplate:
    """A compiled weight-preserving template.

    Attributes
    ----------
    num_qubits : int
        ``n``.
    occupied : tuple of int
        Qubits set to 1 by X gates on ``|0...0>``; ``weight = len(occupied)`` is ``k``.
    gates : list of GateOp
        In circuit order.
    measured : list of int or None
        Per clbit, the qubit it measures last (None: never measured, reads 0).
    parameters : tuple
        ``circuit.parameters`` (the columns of a parameter row).
    flipped : tuple of int
        Clbits whose qubit went through a bit flip (X, Y, or any one-qubit gate whose matrix
        is X up to phases) after the weight-preserving gates and right before its
        measurement: a relabelling of that clbit, applied to the drawn bits. Outcomes keep
        weight ``k`` only when this is empty.
    """

    num_qubits: int
    occupied: tuple
    gates: list
    measured: list
    parameters: tuple
    name: str = ""
    flipped: tuple = ()
    dimension: int = field(init=False)

    def __post_init__(self):
        self.dimension = math.comb(self.num_qubits, len(self.occupied))

    @property
    def weight(self) -> int:
        """The Hamming weight ``k`` of the state before any final bit flip (every outcome's
        when :attr:`flipped` is empty)."""
        return len(self.occupied)

    @property
    def unary(self) -> bool:
        """Weight 1 and only RBS / FBS gates with angles linear in one parameter: the unary
        engine's circuits."""
        return self.weight == 1 and all(
            g.name in GIVENS_GATES and g.angles[0].kind != "expr" for g in self.gates)

    @property
    def real(self) -> bool:
        """Whether every gate keeps real amplitudes real."""
        return all(g.real for g in self.gates)


def _angle(value, position: dict, inst_name: str) -> Angle:
    if isinstance(value, Parameter):  # the common case: the angle is a parameter itself
        return _parameter_angle(position[value])
    if not isinstance(value, ParameterExpression) or not value.parameters:
        return Angle("const", offset=float(value))
    if len(value.parameters) == 1:
        (param,) = value.parameters
        grad = value.gradient(param)
        if not (isinstance(grad, ParameterExpression) and grad.parameters):
            a = float(grad)
            return Angle("linear", offset=float(value.bind({param: 0.0})),
                         index=position[param], coefficient=a)
    return Angle("expr", expr=value, indices=tuple(position[p] for p in value.parameters))


@lru_cache(maxsize=2**16)
def _parameter_angle(index: int) -> Angle:
    """The angle that is parameter ``index`` itself: one frozen object shared by every gate
    and template (a template at n = 256 holds about 800 of them)."""
    return Angle("linear", offset=0.0, index=index, coefficient=1.0)


def _is_bit_flip(op) -> bool:
    """Whether a one-qubit gate without free parameters has X's matrix up to phases
    (``|0> <-> |1>``: X, Y, ``RX(pi)``, ...)."""
    if any(isinstance(p, ParameterExpression) and p.parameters for p in op.params):
        return False
    try:
        mat = Operator(op).data
    except Exception:  # no matrix (opaque gate)
        return False
    return bool(mat.shape == (2, 2) and abs(mat[0, 0]) < _TOL and abs(mat[1, 1]) < _TOL)


def _matrix_preserves(mat: np.ndarray) -> bool:
    w = np.array([bin(i).count("1") for i in range(mat.shape[0])])
    return not np.any(np.abs(mat[w[:, None] != w[None, :]]) > _TOL)


def _refuse(label: str, index: int, name: str, qubits, why: str) -> NoReturn:
    raise UnsupportedInstructionError(
        f"HammingWeightSampler cannot sample {label!r}: instruction {index} {name!r} on qubits "
        f"{list(qubits)} {why}; it samples X gates on |0...0> followed by Hamming-weight-"
        f"preserving gates (RBS, FBS, XXPlusYY, phases, RZ, CZ, SWAP, any gate whose matrix "
        f"commutes with the number operator) and final Z-basis measurements; {_ALTERNATIVE}")


class _Walker:
    def __init__(self, circuit: QuantumCircuit, label: str):
        self.n = circuit.num_qubits
        self.label = label
        self.parameters = tuple(circuit.parameters)  # a sorted view built on each read
        self.position = {p: i for i, p in enumerate(self.parameters)}
        self.bits: list = [0] * self.n  # 0/1 while a basis state, None once acted on
        self.gates: list[GateOp] = []
        self.measured: list = [None] * circuit.num_clbits
        self.done: set[int] = set()  # measured qubits: no gate may follow
        self.top_index = 0
        self.initial: set[int] = set()  # qubits at 1 when a gate first acted on them
        # qubits flipped (a relabelling) since a gate acted on them: instruction index
        self.pending: dict[int, int] = {}
        self.flipped: set[int] = set()  # clbits that read a flipped qubit

    def walk(self, circuit: QuantumCircuit, qmap: list[int], cmap: list[int] | None,
             top: str | None = None, start: int = 0) -> None:
        qindex = {q: i for i, q in enumerate(circuit.qubits)}  # find_bit, once per bit
        cindex = {c: i for i, c in enumerate(circuit.clbits)}
        data = circuit.data if not start else circuit.data[start:]
        for index, inst in enumerate(data, start):
            if top is None:
                self.top_index = index
            op = inst.operation
            name = op.name
            qs = [qmap[qindex[q]] for q in inst.qubits]
            shown = top or name
            if name in _SKIPPED:
                continue
            if getattr(op, "condition", None) is not None or op.name in (
                    "if_else", "while_loop", "for_loop", "switch_case", "box"):
                _refuse(self.label, self.top_index, shown, qs, "is classically controlled")
            if name == "measure":
                if cmap is None:
                    _refuse(self.label, self.top_index, shown, qs, "measures inside a gate")
                clbit = cmap[cindex[inst.clbits[0]]]
                self.measured[clbit] = qs[0]
                if qs[0] in self.pending:
                    self.flipped.add(clbit)
                else:
                    self.flipped.discard(clbit)
                self.done.add(qs[0])
                continue
            if self.done.intersection(qs):
                _refuse(self.label, self.top_index, shown, qs,
                        "acts after a measurement (mid-circuit measurements are not sampled)")
            if name == "reset" and self.bits[qs[0]] == 0:
                continue
            flip = name in _FLIPS or (len(qs) == 1 and name not in KNOWN_GATES
                                      and _is_bit_flip(op))
            if flip and self.bits[qs[0]] is not None:
                self.bits[qs[0]] ^= 1
                continue
            if flip:  # a relabelling of the outcome, if nothing but a measurement follows
                if self.pending.pop(qs[0], None) is None:
                    self.pending[qs[0]] = self.top_index
                continue
            if self.pending.keys() & set(qs):
                q = next(q for q in qs if q in self.pending)
                _refuse(self.label, self.top_index, shown, qs,
                        f"acts on qubit {q} after the bit flip of instruction "
                        f"{self.pending[q]} (a flip is absorbed only right before the "
                        f"qubit's measurement: X gates otherwise only prepare the input on "
                        f"|0...0>)")
            if name in KNOWN_GATES:
                self._known(inst, qs)
                continue
            if self._by_matrix(op, qs):
                continue
            if op.definition is not None and name not in ("reset",):
                self.walk(op.definition, qs, None, shown)
                continue
            _refuse(self.label, self.top_index, shown, qs, "does not preserve Hamming weight")

    def _touch(self, qs) -> None:
        for q in qs:
            if self.bits[q] == 1:
                self.initial.add(q)
            self.bits[q] = None

    def _known(self, inst, qs) -> None:
        op = inst.operation
        angles = tuple(_angle(v, self.position, op.name) for v in op.params)
        if GATES[op.name].fixed:
            self._fixed(op, qs)
            return
        if GATES.get(op.name) is FBS:
            self._touch(qs)
            self.gates.append(GateOp("fbs", tuple(qs), angles, position=self.top_index))
            return
        self._touch(qs)
        self.gates.append(GateOp(op.name, tuple(qs), angles, position=self.top_index))

    def _fixed(self, op, qs) -> None:
        mat = Operator(op).data
        self._touch(qs)
        self.gates.append(GateOp(op.name, tuple(qs), matrix=mat, position=self.top_index))

    def _by_matrix(self, op, qs) -> bool:
        """A gate outside the known list judged by its matrix (fixed or bound at random)."""
        m = len(qs)
        if m > MATRIX_MAX_QUBITS or m == 0:
            return False
        free = [p for p in op.params if isinstance(p, ParameterExpression) and p.parameters]
        try:
            if not free:
                mat = Operator(op).data
            else:
                qc = QuantumCircuit(m)
                qc.append(op, range(m))
                rng = np.random.default_rng(12345)
                mats = [Operator(qc.assign_parameters(dict(zip(
                    qc.parameters, rng.uniform(-3, 3, qc.num_parameters).tolist(),
                    strict=True)))).data for _ in range(2)]
                if not all(_matrix_preserves(x) for x in mats):
                    return False
                self._touch(qs)
                self.gates.append(GateOp(op.name, tuple(qs), operation=(qc, [
                    self.position[p] for p in qc.parameters]), position=self.top_index))
                return True
        except Exception:  # no matrix (opaque gate): judged through its definition, if any
            return False
        if not _matrix_preserves(mat):
            return False
        self._touch(qs)
        self.gates.append(GateOp(op.name, tuple(qs), matrix=mat, position=self.top_index))
        return True


def compile_template(circuit: QuantumCircuit, label: str | None = None, *,
                     prefix: CompiledPrefix | None = None) -> HammingTemplate:
    """Compile ``circuit`` for the Hamming-weight sampler (gate list, angles, measurements).

    Parameters
    ----------
    circuit : QuantumCircuit
        X (or Y) gates on qubits still in ``|0>`` or ``|1>`` prepare the input; every other gate
        must commute with the number operator on its qubits; measurements are final.
    label : str, optional
        Names the circuit in error messages (default ``circuit.name``).

    Returns
    -------
    HammingTemplate

    Raises
    ------
    ValueError
        Naming the first instruction outside that scope and the alternative (Aer).
    """
    if not isinstance(circuit, QuantumCircuit):
        raise TypeError(f"circuit must be a QuantumCircuit, got {type(circuit).__name__}")
    w = _Walker(circuit, label or circuit.name)
    start = 0
    if prefix is not None and prefix.resume(w):
        start = prefix.size
    w.walk(circuit, list(range(circuit.num_qubits)), list(range(circuit.num_clbits)),
           start=start)
    occupied = tuple(q for q in range(circuit.num_qubits)
                     if w.bits[q] == 1 or (w.bits[q] is None and q in w.initial))
    return HammingTemplate(circuit.num_qubits, occupied, w.gates, w.measured,
                           w.parameters, label or circuit.name, tuple(sorted(w.flipped)))


class CompiledPrefix:
    """The walk of a circuit's first instructions done once, for templates that all begin with
    them: a density gradient plan compiles ``V(x) U_k`` for every ``k``, and at ``n = 1024``
    the loader ``V(x)`` is 1,023 of its 1,535 gates. :func:`compile_template` ``(circuit,
    prefix=...)`` resumes after them, the prefix's gates taken with their parameter columns
    renumbered to ``circuit.parameters``, and walks the rest: the same template as the whole
    walk.

    Parameters
    ----------
    prefix : QuantumCircuit
        Without classical bits. The caller guarantees that every circuit compiled with it
        begins with these instructions, on the same qubits.

    A prefix this does not cover (gates judged by their matrices, angles not linear in one
    parameter, bit flips still pending, a refused instruction) is walked with the rest.
    """

    def __init__(self, prefix: QuantumCircuit):
        self.size = len(prefix.data)
        self.num_qubits = prefix.num_qubits
        self.ok = False
        if prefix.num_clbits or prefix.num_vars:
            return
        w = _Walker(prefix, prefix.name)
        try:
            w.walk(prefix, list(range(prefix.num_qubits)), [])
        except ValueError:
            return
        self.parameters = w.parameters
        self.bits, self.initial, self.gates = tuple(w.bits), frozenset(w.initial), w.gates
        self.ok = not (w.pending or w.done or w.flipped) and all(
            g.operation is None and all(a.kind != "expr" for a in g.angles) for g in w.gates)

    def resume(self, w: _Walker) -> bool:
        """Put the walker ``w`` (of a circuit that begins with the prefix) where the walk
        of the prefix leaves it; False (``w`` untouched) where this prefix cannot."""
        if not self.ok or w.n != self.num_qubits:
            return False
        try:
            column = [w.position[p] for p in self.parameters]
        except KeyError:
            return False
        gates = []
        for g in self.gates:
            angles = tuple(a if a.kind != "linear" else (
                _parameter_angle(column[a.index]) if a.coefficient == 1.0 and a.offset == 0.0
                else Angle("linear", a.offset, column[a.index], a.coefficient))
                for a in g.angles)
            gates.append(GateOp(g.name, g.qubits, angles, g.matrix, None, g.position))
        w.bits, w.initial, w.gates = list(self.bits), set(self.initial), gates
        return True
