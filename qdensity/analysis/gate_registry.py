"""The gate registry: everything the toolkit knows about a gate kind, in one entry per name.

Each :class:`GateKind` states, for one instruction name, its matrix and decomposition (for the
gates qdensity defines; Qiskit's standard gates keep their own), its Pauli generator
``G`` with ``gate(angle) = exp(-i angle G)``, its parameter-shift rule, whether it preserves
Hamming weight, whether it is real or diagonal, and how it acts on unary amplitudes.
Every layer reads these entries (structure analysis, shift rules, the unary, statevector and
sampler engines, controlled preparations); no other module compares gate names to the names
defined here (``tests/analysis/test_gate_registry.py`` greps the package for it).

Conventions (docs/design.md, "Conventions"): ``RBS(theta)`` on ``[i, j]`` has the paper's
matrix ``[[1,0,0,0],[0,c,-s,0],[0,s,c,0],[0,0,0,1]]`` (basis index ``q_i + 2 q_j``) and
generator ``Q = (X_i Y_j - Y_i X_j) / 2`` (paper eq. 8); ``FBS(theta)`` on ``[i, ..., j]`` acts
as ``RBS((-1)^p theta)`` on ``(i, j)``, ``p`` the parity of the qubits strictly between
(Supp. E, eq. 24-25), generator ``Q Z_{i+1} ... Z_{j-1}``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from qiskit.circuit import QuantumCircuit, QuantumRegister
from qiskit.quantum_info import PauliList, SparsePauliOp

from qdensity.validation import CallableC, Instance, Options, validates

__all__ = ["GateKind", "GATES", "gate_kind", "register_gate", "RBS", "FBS", "EVOLUTION",
           "GIVENS_GATES", "PHASE_GATES", "CONTROLLED_PHASE_GATES", "UNARY_ACTIONS",
           "SHIFT_RULES"]

#: How a gate acts on unary amplitudes (Hamming weight 1): ``"givens"`` rotates the plane of
#: its first and last qubit by ``+theta`` (``y_i -> c y_i - s y_j``, ``y_j -> s y_i + c y_j``).
UNARY_ACTIONS = ("givens",)
#: Parameter-shift rules: ``"four_term"`` (Supp. E, eq. 23; the two-term variant on request),
#: ``"generator"`` (read off the spectrum of the generator).
SHIFT_RULES = ("four_term", "generator")


@validates(
    name=Instance(str), generator=[CallableC("f(operation, qubits, num_qubits)"), None],
    shift_rule=[Options(SHIFT_RULES), None], preserves_hamming_weight=Instance(bool),
    real=Instance(bool), diagonal=Instance(bool), unary=[Options(UNARY_ACTIONS), None],
    fixed_generator=Instance(bool),
    matrix=[CallableC("f(params, num_qubits) -> ndarray"), None],
    decomposition=[CallableC("f(params, num_qubits) -> QuantumCircuit"), None],
    block=[CallableC("f(*angles) -> ndarray of shape (B, 2**m, 2**m)"), None],
    fixed=Instance(bool),
)
@dataclass(frozen=True)
class GateKind:
    """What the toolkit knows about one instruction name.

    Attributes
    ----------
    name : str
        The ``Instruction.name`` this entry describes.
    generator : callable or None
        ``generator(operation, qubits, num_qubits) -> SparsePauliOp``: the Hermitian ``G`` with
        ``gate(angle) = exp(-i angle G)`` placed on ``qubits`` of a ``num_qubits`` register;
        None when the gate has no angle or no Pauli form.
    shift_rule : {"four_term", "generator"} or None
        How a gradient shifts the angle: the four-term rule of Supp. E (``"four_term"``, the
        RBS family) or the rule read off the generator's spectrum.
    preserves_hamming_weight : bool
        Whether the instruction maps every Hamming-weight-k subspace to itself.
    real : bool
        Whether its matrix is real for every angle.
    diagonal : bool
        Whether its matrix is diagonal for every angle (it keeps a basis state a basis state).
    unary : {"givens"} or None
        How it acts on unary amplitudes (see :data:`UNARY_ACTIONS`); None if not a two-mode
        rotation.
    fixed_generator : bool
        Whether the generator depends only on the name and the width (True for every gate
        with a generator except ``PauliEvolution``, whose operator is its own).
    matrix : callable or None
        ``matrix(params, num_qubits) -> ndarray`` of shape ``(2**m, 2**m)``, little-endian; None
        for Qiskit's standard gates (their own ``to_matrix``).
    decomposition : callable or None
        ``decomposition(params, num_qubits) -> QuantumCircuit`` in standard gates (and, for
        FBS, the RBS gate given as ``core=``); None for Qiskit's standard gates.
    block : callable or None
        ``block(*angles) -> ndarray`` of shape ``(B, 2**m, 2**m)``: the local matrix for ``B``
        values of each angle at once (arrays of shape ``(B,)``), little-endian; what the
        Hamming-weight sampler applies row by row. None where no such form is written.
    fixed : bool
        Whether the gate has no parameter (its matrix is a constant).

    Examples
    --------
    >>> from qdensity.analysis import gate_kind
    >>> rbs = gate_kind("rbs")
    >>> rbs.preserves_hamming_weight, rbs.real, rbs.shift_rule
    (True, True, 'four_term')
    """

    name: str
    generator: Callable | None = None
    shift_rule: str | None = None
    preserves_hamming_weight: bool = False
    real: bool = False
    diagonal: bool = False
    unary: str | None = None
    fixed_generator: bool = True
    matrix: Callable | None = None
    decomposition: Callable | None = None
    block: Callable | None = None
    fixed: bool = False

    def __reduce_ex__(self, protocol):
        # a registered entry (its functions may be closures or lambdas) pickles and copies as
        # its name: it loads as the entry registered under that name
        if GATES.get(self.name) is self:
            return (_registered, (self.name,))
        return super().__reduce_ex__(protocol)


#: The registry: instruction name -> :class:`GateKind`.
GATES: dict[str, GateKind] = {}


def _registered(name: str):
    """The registered entry ``name`` (what a registered entry pickles to)."""
    return GATES[name]


@validates(kind=Instance(GateKind))
def register_gate(kind: GateKind) -> GateKind:
    """Add ``kind`` to :data:`GATES` (one entry per name) and return it.

    Raises
    ------
    ValueError
        If a kind with the same name is registered already.

    Examples
    --------
    A new name registers once; the same name again is refused:

    >>> kind = register_gate(GateKind("my_phase", diagonal=True))
    >>> gate_kind("my_phase").diagonal
    True
    >>> register_gate(GateKind("my_phase"))
    Traceback (most recent call last):
        ...
    ValueError: kind: a gate named 'my_phase' is registered already
    >>> del GATES["my_phase"]  # leave the registry as it was
    """
    if kind.name in GATES:
        raise ValueError(f"kind: a gate named {kind.name!r} is registered already")
    GATES[kind.name] = kind
    return kind


@validates(name=Instance(str))
def gate_kind(name: str) -> GateKind | None:
    """The registered :class:`GateKind` of instruction ``name``, or None if none is known.

    Examples
    --------
    >>> gate_kind("rbs").unary
    'givens'
    >>> gate_kind("no_such_gate") is None
    True
    """
    return GATES.get(name)


# --- generators (placed on the gate's qubits, on the whole register) -------------------------

def _single(letters: str, coeff: float) -> Callable:
    def gen(op, q, n):
        return SparsePauliOp.from_sparse_list([(letters, q, coeff)], n)
    return gen


def _controlled(letter: str) -> Callable:
    def gen(op, q, n):
        return SparsePauliOp.from_sparse_list([(letter, q[1:], 0.25),
                                               ("Z" + letter, q, -0.25)], n)
    return gen


def _phase(op, q, n):
    return SparsePauliOp.from_sparse_list([("Z", q, 0.5), ("", [], -0.5)], n)


def _controlled_phase(op, q, n):
    return SparsePauliOp.from_sparse_list(
        [("", [], -0.25), ("Z", q[:1], 0.25), ("Z", q[1:], 0.25), ("ZZ", q, -0.25)], n)


def _rbs_generator(op, q, n):
    # ("XY", [i, j]) - ("YX", [i, j]) over 2: X on i, Y on j; built from the bits directly
    x = np.zeros((2, n), dtype=bool)
    z = np.zeros((2, n), dtype=bool)
    x[:, q] = True
    z[0, q[1]] = z[1, q[0]] = True
    return SparsePauliOp(PauliList.from_symplectic(z, x), np.array([0.5, -0.5]))


def _fbs_generator(op, q, n):
    i, j, inner = q[0], q[-1], q[1:-1]
    zs = "Z" * len(inner)
    return SparsePauliOp.from_sparse_list(
        [("X" + zs + "Y", [i, *inner, j], 0.5), ("Y" + zs + "X", [i, *inner, j], -0.5)], n)


def _evolution_generator(op, q, n):
    operator = op.operator
    if isinstance(operator, list):
        raise ValueError("PauliEvolutionGate with a list of operators is not supported")
    return _placed(operator if isinstance(operator, SparsePauliOp) else SparsePauliOp(operator),
                   list(q), n)


def _placed(op: SparsePauliOp, qubits: list[int], n: int) -> SparsePauliOp:
    """``op.apply_layout(qubits, n)`` from the symplectic bits directly (no compose)."""
    if op.num_qubits != len(qubits):
        return op.apply_layout(qubits, n)  # raises Qiskit's own error
    pl = op.paulis
    x = np.zeros((op.size, n), dtype=bool)
    z = np.zeros((op.size, n), dtype=bool)
    x[:, qubits] = pl.x
    z[:, qubits] = pl.z
    return SparsePauliOp(PauliList.from_symplectic(z, x, pl.phase), op.coeffs.copy())


# --- matrices and decompositions of the gates qdensity defines -------------------------------

def _rbs_matrix(params: Sequence, num_qubits: int = 2) -> np.ndarray:
    c, s = math.cos(float(params[0])), math.sin(float(params[0]))
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=complex)


def _fbs_matrix(params: Sequence, num_qubits: int) -> np.ndarray:
    theta, m = float(params[0]), int(num_qubits)
    out = np.eye(2**m, dtype=complex)
    last = m - 1
    for b in range(2**m):
        if b & 1 and not (b >> last) & 1:  # |1 on first, 0 on last>  -> pair (b, partner)
            partner = b ^ 1 ^ (1 << last)
            inner = (b >> 1) & ((1 << (m - 2)) - 1) if m > 2 else 0
            sign = -1.0 if bin(inner).count("1") % 2 else 1.0
            c, s = math.cos(sign * theta), math.sin(sign * theta)
            out[b, b] = out[partner, partner] = c
            out[partner, b], out[b, partner] = s, -s
    return out


def _rbs_decomposition(params: Sequence, num_qubits: int = 2) -> QuantumCircuit:
    """Two CZ (the minimum): ``(H (x) H) CZ (RY(theta) (x) RY(-theta)) CZ (H (x) H)``."""
    (theta,) = params
    qc = QuantumCircuit(QuantumRegister(2, "q"), name="rbs")
    qc.h([0, 1])
    qc.cz(0, 1)
    qc.ry(theta, 0)
    qc.ry(-theta, 1)
    qc.cz(0, 1)
    qc.h([0, 1])
    return qc


def _fbs_decomposition(params: Sequence, num_qubits: int, core: Callable | None = None
                       ) -> QuantumCircuit:
    """Eq. 25: the parity of the inner qubits onto qubit 1 with CNOTs, a CZ from it around the
    RBS of the end qubits (``Z RBS(theta) Z = RBS(-theta)``), the parity undone. ``core(theta)``
    makes the RBS gate (default: its decomposition as one gate)."""
    (theta,) = params
    m, last = int(num_qubits), int(num_qubits) - 1
    rbs = core(theta) if core is not None else _rbs_decomposition([theta]).to_gate()
    qc = QuantumCircuit(QuantumRegister(m, "q"), name="fbs")
    if m == 2:
        qc.append(rbs, [0, last])
        return qc
    parity = 1
    for k in range(2, last):
        qc.cx(k, parity)
    qc.cz(parity, 0)
    qc.append(rbs, [0, last])
    qc.cz(parity, 0)
    for k in reversed(range(2, last)):
        qc.cx(k, parity)
    return qc


# --- vectorised local matrices (B angle values at once) ----------------------------------------


def _diagonal(*phases: np.ndarray) -> np.ndarray:
    d = np.stack(np.broadcast_arrays(*phases), axis=1).astype(complex)
    out = np.zeros(d.shape + (d.shape[1],), dtype=complex)
    idx = np.arange(d.shape[1])
    out[:, idx, idx] = d
    return out


def _rbs_block(theta: np.ndarray) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    m = np.zeros((np.size(c), 4, 4))
    m[:, 0, 0] = m[:, 3, 3] = 1.0
    m[:, 1, 1] = m[:, 2, 2] = c
    m[:, 1, 2], m[:, 2, 1] = -s, s
    return m


def _xx_plus_yy_block(theta: np.ndarray, beta: np.ndarray) -> np.ndarray:
    theta, beta = np.broadcast_arrays(theta, beta)
    c, s = np.cos(theta / 2), np.sin(theta / 2)
    m = np.zeros((c.size, 4, 4), dtype=complex)
    m[:, 0, 0] = m[:, 3, 3] = 1.0
    m[:, 1, 1] = m[:, 2, 2] = c
    m[:, 1, 2] = -1j * s * np.exp(-1j * beta)
    m[:, 2, 1] = -1j * s * np.exp(1j * beta)
    return m


def _one(x: np.ndarray) -> np.ndarray:
    return np.ones_like(x, dtype=complex)


def _rotation_block(pauli: str) -> Callable:
    def block(theta: np.ndarray) -> np.ndarray:
        c, s = np.cos(np.asarray(theta) / 2), np.sin(np.asarray(theta) / 2)
        m = np.empty((c.size, 2, 2), dtype=complex)
        m[:, 0, 0] = m[:, 1, 1] = c
        m[:, 0, 1], m[:, 1, 0] = (-1j * s, -1j * s) if pauli == "x" else (-s, s)
        return m

    return block


_BLOCKS: dict[str, Callable] = {
    "rx": _rotation_block("x"),
    "ry": _rotation_block("y"),
    "rz": lambda lam: _diagonal(np.exp(-0.5j * lam), np.exp(0.5j * lam)),
    "p": lambda lam: _diagonal(_one(lam), np.exp(1j * lam)),
    "rzz": lambda t: _diagonal(np.exp(-0.5j * t), np.exp(0.5j * t), np.exp(0.5j * t),
                               np.exp(-0.5j * t)),
    "cp": lambda lam: _diagonal(_one(lam), _one(lam), _one(lam), np.exp(1j * lam)),
    "crz": lambda t: _diagonal(_one(t), np.exp(-0.5j * t), _one(t), np.exp(0.5j * t)),
}
_BLOCKS["u1"], _BLOCKS["cu1"] = _BLOCKS["p"], _BLOCKS["cp"]


# --- the entries (in this order: GENERATOR_GATES and messages list them so) --------------------

for _p in "xyz":
    register_gate(GateKind("r" + _p, _single(_p.upper(), 0.5), "generator",
                           preserves_hamming_weight=_p == "z", real=_p == "y",
                           diagonal=_p == "z", block=_BLOCKS.get("r" + _p)))
for _p in "xyz":
    register_gate(GateKind("r" + _p * 2, _single(_p.upper() * 2, 0.5), "generator",
                           preserves_hamming_weight=_p == "z", diagonal=_p == "z",
                           block=_BLOCKS.get("r" + _p * 2)))
register_gate(GateKind("rzx", _single("ZX", 0.5), "generator"))
for _p in "xyz":
    register_gate(GateKind("cr" + _p, _controlled(_p.upper()), "generator",
                           preserves_hamming_weight=_p == "z", diagonal=_p == "z",
                           block=_BLOCKS.get("cr" + _p)))
for _name in ("p", "u1"):
    register_gate(GateKind(_name, _phase, "generator", preserves_hamming_weight=True,
                           diagonal=True, block=_BLOCKS[_name]))
for _name in ("cp", "cu1"):
    register_gate(GateKind(_name, _controlled_phase, "generator", preserves_hamming_weight=True,
                           diagonal=True, block=_BLOCKS[_name]))
RBS = register_gate(GateKind(
    "rbs", _rbs_generator, "four_term", preserves_hamming_weight=True, real=True,
    unary="givens", matrix=_rbs_matrix, decomposition=_rbs_decomposition, block=_rbs_block))
FBS = register_gate(GateKind(
    "fbs", _fbs_generator, "four_term", preserves_hamming_weight=True, real=True,
    unary="givens", matrix=_fbs_matrix, decomposition=_fbs_decomposition))
EVOLUTION = register_gate(GateKind("PauliEvolution", _evolution_generator, "generator",
                                   fixed_generator=False))
for _name in ("z", "cz", "swap", "id"):  # fixed, real and weight-preserving
    register_gate(GateKind(_name, preserves_hamming_weight=True, real=True,
                           diagonal=_name != "swap", fixed=True))
for _name in ("s", "sdg", "t", "tdg", "iswap"):
    register_gate(GateKind(_name, preserves_hamming_weight=True,
                           diagonal=_name in ("s", "sdg", "t", "tdg"), fixed=True))
register_gate(GateKind("xx_plus_yy", preserves_hamming_weight=True, block=_xx_plus_yy_block))
for _name in ("barrier", "measure", "delay"):  # not gates: they pass any weight through
    register_gate(GateKind(_name, preserves_hamming_weight=True))

#: Names of the gates that act on unary amplitudes as Givens rotations (``unary="givens"``):
#: the gates of the unary engine and of the Hamming-weight-preserving ansatze.
GIVENS_GATES = tuple(name for name, kind in GATES.items() if kind.unary == "givens")
#: Names of the phase gates ``diag(1, e^{i lambda})`` (generator ``-|1><1|``; Qiskit's alias pair).
PHASE_GATES = tuple(name for name, kind in GATES.items() if kind.generator is _phase)
#: Names of the controlled phase gates (generator ``-|11><11|``).
CONTROLLED_PHASE_GATES = tuple(name for name, kind in GATES.items()
                               if kind.generator is _controlled_phase)
