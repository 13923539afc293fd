"""Statevector operations of the adjoint engine: a circuit compiled to Pauli rotations.

Every parameterised gate the builders emit is a product of (controlled) Pauli rotations
``exp(-i angle c Pi P)``, ``Pi`` the projector on its controls being ``|1>`` (identity when
it has none) and ``P`` a Pauli string on the other qubits:

* ``rx, ry, rz``: ``c = 1/2``; ``rxx, ryy, rzz, rzx``: two-qubit strings, ``c = 1/2``;
* ``crx, cry, crz``: generator ``|1><1| (x) P/2`` (one control);
* ``p``/``u1`` and ``cp``/``cu1``: ``P = I``, ``c = -1`` (a phase ``e^{i angle}`` on ``Pi``);
  ``u``/``u3``: ``RZ RY RZ`` (equal up to a global phase);
* ``rbs``: ``Q = (X_i Y_j - Y_i X_j)/2`` is two commuting strings, so ``RBS = exp(-i t X_i Y_j
  / 2) exp(+i t Y_i X_j / 2)`` exactly; ``fbs`` multiplies both strings by ``Z`` on the inner
  qubits (the parity sign of Supp. E eq. 24);
* ``PauliEvolutionGate``: one rotation per term of its operator (the terms must commute).

Fixed Pauli gates (``x, y, z, cx, cy, cz, ccx``) are applied as (controlled) Pauli strings,
other fixed gates by their matrix, and other parameterised gates through their definition.

States are flat arrays of shape ``(..., R, 2**n)``: leading batch axes, ``R`` parameter rows,
amplitude ``k = sum_q b_q 2^q`` (Qiskit's convention). A gate is ``k -> k ^ x`` with a sign, on
the positions where its controls are 1, done on the state viewed as a tensor ``(..., R, 2, ...,
2)``: reversed axes, slices and small broadcast sign tables, never a ``2**n`` index table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.circuit import ParameterExpression, QuantumCircuit

from qdensity.analysis.gate_registry import (
    CONTROLLED_PHASE_GATES,
    EVOLUTION,
    GATES,
    GIVENS_GATES,
    PHASE_GATES,
)

__all__ = ["Rotation", "Fixed", "Program", "LinearMap", "compile_program", "SUPPORTED", "cdot",
           "real_dot"]

SUPPORTED = ("rx, ry, rz, rxx, ryy, rzz, rzx, crx, cry, crz, p, u1, cp, cu1, u, u3, rbs, fbs, "
             "PauliEvolution (commuting terms), any fixed gate with a matrix, and gates whose "
             "definition uses these")

_SKIP = frozenset({"barrier", "delay", "id", "global_phase"})
_ROT = {"rx": "X", "ry": "Y", "rz": "Z", "rxx": "XX", "ryy": "YY", "rzz": "ZZ", "rzx": "ZX"}
_CROT = {"crx": "X", "cry": "Y", "crz": "Z"}
_FIXED_PAULI = {"x": (0, "X"), "y": (0, "Y"), "z": (0, "Z"), "cx": (1, "X"), "cy": (1, "Y"),
                "cz": (1, "Z"), "ccx": (2, "X"), "ccz": (2, "Z")}


def real_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``Re sum_k conj(a_k) b_k`` over the last axis (broadcast): one real product of the
    arrays' float views. (``np.vecdot`` on complex rows of shape (1, 2**16) took 2-17 ms in
    numpy 2.4, a hundred times this.)"""
    return np.einsum("...k,...k->...", a.view(np.float64), b.view(np.float64))


def cdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``sum_k conj(a_k) b_k`` over the last axis (broadcast), complex."""
    return np.einsum("...k,...k->...", a.conj(), b)


#: Most ``Z`` qubits whose signs one broadcast table holds (``2**_SIGN_AXES`` entries);
#: a string with more multiplies the state by several such tables.
_SIGN_AXES = 10


class _Gather:
    """``(P psi)[k] = factor[k] psi[k ^ x]`` on the positions ``k`` where every control is 1.

    ``Y|b> = i (-1)^b |1-b>``, so ``(P psi)[k] = (-i)^{#Y} (-1)^{|k & z|} psi[k ^ x]`` with
    ``x`` the X/Y qubits and ``z`` the Y/Z qubits. States are flat, shape ``(..., R, 2**n)``,
    and are worked on as tensors ``(..., R, 2, ..., 2)`` (qubit ``q`` on axis ``-1 - q``):
    the controlled positions are a view (index 1 on the control axes), ``k -> k ^ x`` is a
    reversal of the ``x`` axes (a view) and the parity signs are broadcast tables on the ``z``
    axes (``2**|z|`` entries at most, in pieces of ``2**_SIGN_AXES``). So a gate costs a few
    passes over the state and allocates nothing of size ``2**n`` but its result: no index or
    parity table of ``2**n`` entries is ever built.
    """

    def __init__(self, letters: dict[int, str], n: int, phase: complex = 1.0,
                 controls: tuple[int, ...] = ()):
        self.n = n
        self.xmask = sum(1 << q for q, p in letters.items() if p in "XY")
        self.zmask = sum(1 << q for q, p in letters.items() if p in "YZ")
        ny = sum(1 for p in letters.values() if p == "Y")
        self.scalar = complex(phase) * (-1j) ** ny
        self.cmask = sum(1 << q for q in controls)
        self._xaxes = tuple(-1 - q for q in range(n) if self.xmask >> q & 1)
        zq = [q for q in range(n) if self.zmask >> q & 1]
        self._signs = [_sign_table(zq[i:i + _SIGN_AXES], n)
                       for i in range(0, len(zq), _SIGN_AXES)]
        self._index = (Ellipsis,) + tuple(
            slice(1, 2) if self.cmask >> q & 1 else slice(None) for q in range(n - 1, -1, -1))

    def tensor(self, state: np.ndarray) -> np.ndarray:
        """``state`` (..., 2**n) as a view (..., 2, ..., 2), qubit ``q`` on axis ``-1 - q``."""
        return state.reshape(state.shape[:-1] + (2,) * self.n)

    def factor(self, scale=None):
        """``scale * scalar * (-1)^{|k & z|}`` as one array broadcasting against a tensor
        (``scale``, shape (..., 1), broadcasts over leading axes; the sign tables are folded in
        when there is one)."""
        f = self.scalar if scale is None else scale * self.scalar
        if scale is not None:
            f = np.reshape(f, np.shape(f)[:-1] + (1,) * self.n)
        if len(self._signs) == 1:
            return f * self._signs[0]
        return f

    def select(self, state: np.ndarray) -> np.ndarray:
        """The tensor of ``state`` on the controlled positions (a view)."""
        return self.tensor(state)[self._index] if self.cmask else self.tensor(state)

    def apply(self, state: np.ndarray, scale=None) -> np.ndarray:
        """A new tensor: ``scale * P state`` on the controlled positions (``scale``, shape
        (..., 1), broadcast over the leading axes; default 1)."""
        sel = self.select(state)
        src = np.flip(sel, self._xaxes) if self._xaxes else sel
        fac = self.factor(scale)
        if isinstance(fac, complex) and fac == 1 and not self._signs:
            out = src.copy()
        else:
            out = np.multiply(src, fac)
        if len(self._signs) > 1:
            for sign in self._signs:
                out *= sign
        return out

    def diagonal(self) -> np.ndarray:
        """``scalar (-1)^{|k & z|}`` over all ``2**n`` positions (a diagonal string without
        controls, once per observable), real part."""
        out = np.full((2,) * self.n, np.real(self.scalar))
        for sign in self._signs:
            out = out * sign
        return out.reshape(-1)


def _sign_table(qubits: list[int], n: int) -> np.ndarray:
    """``prod_q (-1)^{b_q}`` over ``qubits``, shape ``(2, ..., 2)`` broadcast against a tensor
    (2 on the axes of ``qubits``, 1 elsewhere), complex (numpy multiplies complex by float
    more slowly than by complex)."""
    table = np.ones((1,) * n, dtype=complex)
    for q in qubits:
        shape = [1] * n
        shape[n - 1 - q] = 2
        table = table * np.array([1.0, -1.0]).reshape(shape)
    return table


@dataclass
class Rotation:
    """``exp(-i angle c Pi P)``; ``angle = offset + sum_j coeffs[j] values[cols[j]]``.

    ``P = I`` (``identity``) is a phase on the controlled positions."""

    gather: _Gather
    coefficient: float
    cols: np.ndarray
    coeffs: np.ndarray
    offset: float
    identity: bool = False

    def apply(self, state: np.ndarray, cos: np.ndarray, msin: np.ndarray) -> None:
        """In place; ``cos`` (R, 1) and ``msin = -i sin`` (R, 1) of ``c * angle`` (``+i sin``
        undoes the gate)."""
        g = self.gather
        sel = g.select(state)  # a view: the state is changed through it
        c = _column(cos, g.n)
        if self.identity:
            sel *= c + _column(msin, g.n)
            return
        p = g.apply(state, msin)
        sel *= c
        sel += p

    def step_back(self, both: np.ndarray, cos: np.ndarray, isin: np.ndarray,
                  need: bool) -> np.ndarray | None:
        """On ``both = [phi, lam_1 .. lam_M]`` (M + 1, R, 2**n): the derivative
        ``2 c Im <lam_m| Pi P |phi>`` per observable and row, shape (M, R) (if ``need``); then
        undo the gate on every state in place (one reversal for all of them)."""
        g = self.gather
        sel = g.select(both)
        p = sel.copy() if self.identity else g.apply(both)
        grad = None
        if need:
            lead = sel.shape[:2]
            grad = 2.0 * self.coefficient * cdot(sel[1:].reshape(lead[0] - 1, lead[1], -1),
                                                 p[0].reshape(lead[1], -1)).imag
        c, s = _column(cos, g.n), _column(isin, g.n)
        if self.identity:
            sel *= c + s
            return grad
        p *= s
        sel *= c
        sel += p
        return grad


def _column(x: np.ndarray, n: int) -> np.ndarray:
    """Per-row factors ``(..., R, 1)`` as ``(..., R, 1, ..., 1)`` against a tensor."""
    return x.reshape(x.shape[:-1] + (1,) * n)


@dataclass
class Fixed:
    """A gate without free parameters: a (controlled) Pauli string or a dense matrix."""

    qubits: tuple[int, ...]
    matrix: np.ndarray | None = None
    gather: _Gather | None = None

    def apply(self, state: np.ndarray, inverse: bool = False) -> None:
        """In place, on a flat state ``(..., R, 2**n)``."""
        if self.gather is not None:
            g = self.gather
            g.select(state)[...] = g.apply(state)  # a Pauli is its own inverse
            return
        n = int(state.shape[-1]).bit_length() - 1
        tensor = state.reshape(state.shape[:-1] + (2,) * n)
        k = len(self.qubits)
        assert self.matrix is not None  # a fixed gate carries its matrix
        mat = self.matrix.conj().T if inverse else self.matrix
        src = [-1 - q for q in reversed(self.qubits)]
        dst = list(range(-k, 0))
        moved = np.moveaxis(tensor, src, dst)
        shape = moved.shape
        # einsum, not @: a (rows x 2**k) by (2**k x 2**k) product is no work for BLAS threads,
        # which on a busy machine make it wait for a core (docs/design.md, "Measured facts")
        out = np.einsum("...j,ij->...i", moved.reshape(shape[:-k] + (2**k,)), mat).reshape(shape)
        tensor[...] = np.moveaxis(out, dst, src)


@dataclass
class Program:
    """A circuit compiled for the adjoint engine.

    Attributes
    ----------
    num_qubits : int
    num_parameters : int
        ``P``, in ``circuit.parameters`` order.
    ops : list of Rotation or Fixed
        In circuit order.
    rotations : list of int
        Positions in ``ops`` of the rotations.
    coefficients : numpy.ndarray, shape (P, G)
        ``d angle_g / d value_p`` of rotation ``g``.
    offsets, scales : numpy.ndarray, shape (G,)
        Angle offsets and the generator coefficients ``c`` of the rotations.
    """

    num_qubits: int
    num_parameters: int
    ops: list
    rotations: list[int]
    coefficients: np.ndarray
    offsets: np.ndarray
    scales: np.ndarray

    def angles(self, values: np.ndarray) -> np.ndarray:
        """Rotation angles ``(R, G)`` for parameter rows ``(R, P)`` (a gather, no product)."""
        lin = self.__dict__.get("_angle_map")
        if lin is None:
            g, p = np.nonzero(self.coefficients.T)
            lin = self.__dict__["_angle_map"] = LinearMap(
                g, p, self.coefficients[p, g], len(self.rotations))
        return lin(values) + self.offsets

    def chain(self, wrt: np.ndarray) -> LinearMap:
        """The map ``d f / d angle (..., G) -> d f / d value[wrt] (..., W)``, made once per
        ``wrt``; ``chain(wrt).sources`` are the rotations that read a parameter in ``wrt``."""
        cache = self.__dict__.setdefault("_chains", {})
        key = wrt.tobytes()
        lin = cache.get(key)
        if lin is None:
            sub = self.coefficients[wrt]  # (W, G)
            w, g = np.nonzero(sub)
            lin = cache[key] = LinearMap(w, g, sub[w, g], wrt.size)
        return lin


class LinearMap:
    """``out[..., t] = sum_e coeffs[e] x[..., sources[e]]`` over the entries ``e`` with
    ``targets[e] = t``: a sparse linear map as one gather, one product and one segmented sum
    (no dense, mostly-zero matrix product, and no BLAS threads)."""

    def __init__(self, targets, sources, coeffs, num_targets: int):
        order = np.argsort(targets, kind="stable")
        targets = np.asarray(targets, dtype=np.intp)[order]
        self.sources = np.unique(sources).astype(np.intp)
        self.num_targets = int(num_targets)
        # every target gets at least one entry: the empty ones read an appended zero column
        counts = np.bincount(targets, minlength=self.num_targets)
        empty = np.flatnonzero(counts == 0)
        self._src = np.concatenate([np.asarray(sources, dtype=np.intp)[order],
                                    np.full(empty.size, -1, dtype=np.intp)])
        self._coef = np.concatenate([np.asarray(coeffs, dtype=float)[order],
                                     np.zeros(empty.size)])
        tgt = np.concatenate([targets, empty])
        order = np.argsort(tgt, kind="stable")
        self._src, self._coef = self._src[order], self._coef[order]
        self._starts = np.searchsorted(tgt[order], np.arange(self.num_targets))
        self._pad = bool(empty.size)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self.num_targets == 0:
            return np.zeros(x.shape[:-1] + (0,))
        if self._pad:
            x = np.concatenate([x, np.zeros(x.shape[:-1] + (1,))], axis=-1)
        taken = np.take(x, self._src, axis=-1)
        taken *= self._coef
        return np.add.reduceat(taken, self._starts, axis=-1)


def _linear(expr, index: dict, gate: str) -> tuple[np.ndarray, np.ndarray, float]:
    """``expr = offset + sum coeffs * values[cols]``, or a ValueError if not linear."""
    if not isinstance(expr, ParameterExpression):
        return np.zeros(0, dtype=int), np.zeros(0), float(np.real(complex(expr)))
    params = list(expr.parameters)
    if not params:
        return np.zeros(0, dtype=int), np.zeros(0), float(np.real(complex(expr)))
    cols, coeffs = [], []
    for p in params:
        g = expr.gradient(p)
        if isinstance(g, ParameterExpression):
            if g.parameters:
                raise ValueError(f"gate {gate!r} angle {expr} is not linear in {p}; the adjoint "
                                 "engine needs angles linear in the parameters")
            g = complex(g)
        cols.append(index[p])
        coeffs.append(float(np.real(complex(g))))
    offset = float(np.real(complex(expr.bind({p: 0.0 for p in params}))))
    return np.array(cols, dtype=int), np.array(coeffs), offset


class _Builder:
    def __init__(self, n: int, index: dict):
        self.n = n
        self.index = index
        self.ops: list = []

    def rotation(self, letters: dict[int, str], c: float, angle, controls=(), gate="") -> None:
        cols, coeffs, offset = _linear(angle, self.index, gate)
        self.ops.append(Rotation(_Gather(letters, self.n, 1.0, tuple(controls)), float(c), cols,
                                 coeffs, offset, not letters))

    def fixed_pauli(self, letters: dict[int, str], controls=()) -> None:
        qs = tuple(controls) + tuple(letters)
        self.ops.append(Fixed(qs, None, _Gather(letters, self.n, 1.0, tuple(controls))))

    def add(self, op, qubits: list[int]) -> None:
        name = op.name
        params = list(op.params)
        if name in _SKIP:
            return
        if name in _ROT:
            self.rotation(dict(zip(qubits, _ROT[name], strict=True)), 0.5, params[0], (), name)
        elif name in _CROT:
            self.rotation({qubits[1]: _CROT[name]}, 0.5, params[0], (qubits[0],), name)
        elif name in PHASE_GATES:
            self.rotation({}, -1.0, params[0], (qubits[0],), name)
        elif name in CONTROLLED_PHASE_GATES:
            self.rotation({}, -1.0, params[0], tuple(qubits), name)
        elif name in GIVENS_GATES:
            i, j, inner = qubits[0], qubits[-1], qubits[1:-1]
            zs = {q: "Z" for q in inner}
            self.rotation({i: "X", j: "Y", **zs}, 0.5, params[0], (), name)
            self.rotation({i: "Y", j: "X", **zs}, -0.5, params[0], (), name)
        elif name in ("u", "u3"):  # U(t, f, l) = RZ(f) RY(t) RZ(l) up to a global phase
            q = qubits[0]
            self.rotation({q: "Z"}, 0.5, params[2], (), name)
            self.rotation({q: "Y"}, 0.5, params[0], (), name)
            self.rotation({q: "Z"}, 0.5, params[1], (), name)
        elif GATES.get(name) is EVOLUTION:
            self._evolution(op, qubits)
        elif name in _FIXED_PAULI and not _free(params):
            nc, letter = _FIXED_PAULI[name]
            self.fixed_pauli({qubits[nc]: letter}, qubits[:nc])
        elif not _free(params) and _has_matrix(op):
            self.ops.append(Fixed(tuple(qubits), np.asarray(op.to_matrix(), dtype=complex)))
        elif getattr(op, "definition", None) is not None:
            inner = op.definition
            for inst in inner.data:
                self.add(inst.operation, [qubits[inner.find_bit(q).index] for q in inst.qubits])
        else:
            raise ValueError(f"the adjoint engine has no rule for gate {name!r}; supported: "
                             f"{SUPPORTED}")

    def _evolution(self, op, qubits: list[int]) -> None:
        from qiskit.quantum_info import SparsePauliOp

        operator = op.operator
        if isinstance(operator, list):
            raise ValueError("PauliEvolutionGate with a list of operators is not supported by "
                             "the adjoint engine; give one SparsePauliOp")
        spo = SparsePauliOp(operator).simplify()
        if len(spo) > 1 and not _all_commute(spo):
            raise ValueError("PauliEvolutionGate with non-commuting terms is not supported by "
                             "the adjoint engine (its product of exponentials is not exact)")
        for pauli, coeff in zip(spo.paulis, spo.coeffs, strict=True):
            c = complex(coeff) * (-1j) ** int(pauli.phase)
            if abs(c.imag) > 1e-12:
                raise ValueError("PauliEvolutionGate needs a Hermitian operator (real "
                                 "coefficients)")
            letters = {}
            for k, q in enumerate(qubits):
                x, z = bool(pauli.x[k]), bool(pauli.z[k])
                if x or z:
                    letters[q] = "Y" if x and z else ("X" if x else "Z")
            if letters:
                self.rotation(letters, c.real, op.params[0], (), "PauliEvolution")


def _free(params) -> bool:
    return any(isinstance(p, ParameterExpression) and p.parameters for p in params)


def _has_matrix(op) -> bool:
    try:
        op.to_matrix()
    except Exception:
        return False
    return True


def _all_commute(spo) -> bool:
    x, z = spo.paulis.x.astype(np.int64), spo.paulis.z.astype(np.int64)
    sym = (x @ z.T + z @ x.T) % 2
    return not np.any(sym)


def compile_program(circuit: QuantumCircuit) -> Program:
    """Compile an unmeasured circuit (no measurements, no resets) for the adjoint engine.

    Parameters
    ----------
    circuit : QuantumCircuit

    Returns
    -------
    Program

    Raises
    ------
    ValueError
        For a measurement, a reset, a non-linear angle or a gate with no rule (the message
        names the gate and the supported families).
    """
    n = circuit.num_qubits
    index = {p: i for i, p in enumerate(circuit.parameters)}
    builder = _Builder(n, index)
    for inst in circuit.data:
        name = inst.operation.name
        if name in ("measure", "reset"):
            raise ValueError(f"the adjoint engine simulates unitary circuits; found {name!r} "
                             "(strip terminal measurements first)")
        builder.add(inst.operation, [circuit.find_bit(q).index for q in inst.qubits])
    ops = builder.ops
    rotations = [i for i, op in enumerate(ops) if isinstance(op, Rotation)]
    P = circuit.num_parameters
    coefficients = np.zeros((P, len(rotations)))
    offsets = np.zeros(len(rotations))
    scales = np.zeros(len(rotations))
    for g, i in enumerate(rotations):
        op = ops[i]
        np.add.at(coefficients[:, g], op.cols, op.coeffs)
        offsets[g] = op.offset
        scales[g] = op.coefficient
    return Program(n, P, ops, rotations, coefficients, offsets, scales)
