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
amplitude ``k = sum_q b_q 2^q`` (Qiskit's convention). A gate is a gather (``k -> k ^ x``) with
a sign, on the positions where its controls are 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.circuit import ParameterExpression, QuantumCircuit

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


#: Index arrays of a gate are kept when the state has at most this many amplitudes.
_CACHE_DIM = 2**16


class _Gather:
    """``(P psi)[k] = factor[k] psi[k ^ x]`` on the positions ``k`` where every control is 1.

    ``Y|b> = i (-1)^b |1-b>``, so ``(P psi)[k] = (-i)^{#Y} (-1)^{|k & z|} psi[k ^ x]`` with
    ``x`` the X/Y qubits and ``z`` the Y/Z qubits. States are flat, shape ``(..., R, 2**n)``.
    """

    def __init__(self, letters: dict[int, str], n: int, phase: complex = 1.0,
                 controls: tuple[int, ...] = ()):
        self.n = n
        self.xmask = sum(1 << q for q, p in letters.items() if p in "XY")
        self.zmask = sum(1 << q for q, p in letters.items() if p in "YZ")
        ny = sum(1 for p in letters.values() if p == "Y")
        self.scalar = complex(phase) * (-1j) ** ny
        self.cmask = sum(1 << q for q in controls)
        self._arrays: tuple | None = None

    def arrays(self):
        """``(idx, src, factor)``: positions (None: all), sources (None: the same) and factors
        (None: 1)."""
        if self._arrays is not None:
            return self._arrays
        k = np.arange(2**self.n, dtype=np.intp)
        idx = k[(k & self.cmask) == self.cmask] if self.cmask else None
        kk = k if idx is None else idx
        src = kk ^ self.xmask if self.xmask else None
        fac = None
        if self.zmask or self.scalar != 1:
            parity = np.bitwise_count(kk & self.zmask) & 1
            # complex even when real: numpy multiplies complex by float far more slowly
            fac = (self.scalar * (1.0 - 2.0 * parity)).astype(complex)
        out = (idx, src, fac)
        if 2**self.n <= _CACHE_DIM:
            self._arrays = out
        return out

    def select(self, state: np.ndarray) -> np.ndarray:
        """``state`` on the controlled positions (a view when there are no controls)."""
        idx = self.arrays()[0]
        return state if idx is None else np.take(state, idx, axis=-1)

    def apply(self, state: np.ndarray) -> np.ndarray:
        """A new array: ``P state`` on the controlled positions."""
        idx, src, fac = self.arrays()
        if src is not None:
            out = np.take(state, src, axis=-1)  # several times faster than state[..., src]
        elif idx is not None:
            out = np.take(state, idx, axis=-1)
        else:
            out = state.copy()
        if fac is not None:
            out *= fac
        return out

    def assign(self, state: np.ndarray, values: np.ndarray) -> None:
        idx = self.arrays()[0]
        if idx is None:
            state[...] = values
        else:
            state[..., idx] = values


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
        if self.identity:
            g.assign(state, g.select(state) * (cos + msin))
            return
        p = g.apply(state)
        p *= msin
        if g.cmask:
            g.assign(state, cos * g.select(state) + p)
        else:
            state *= cos
            state += p

    def step_back(self, both: np.ndarray, cos: np.ndarray, isin: np.ndarray,
                  need: bool) -> np.ndarray | None:
        """On ``both = [phi, lam_1 .. lam_M]`` (M + 1, R, 2**n): the derivative
        ``2 c Im <lam_m| Pi P |phi>`` per observable and row, shape (M, R) (if ``need``); then
        undo the gate on every state in place (one gather for all of them)."""
        g = self.gather
        sel = g.select(both)
        p = sel.copy() if self.identity else g.apply(both)
        grad = 2.0 * self.coefficient * cdot(sel[1:], p[0]).imag if need else None
        if self.identity:
            g.assign(both, sel * (cos + isin))
            return grad
        p *= isin
        if g.cmask:
            g.assign(both, cos * sel + p)
        else:
            both *= cos
            both += p
        return grad


@dataclass
class Fixed:
    """A gate without free parameters: a (controlled) Pauli string or a dense matrix."""

    qubits: tuple[int, ...]
    matrix: np.ndarray | None = None
    gather: _Gather | None = None

    def apply(self, state: np.ndarray, inverse: bool = False) -> None:
        """In place, on a flat state ``(..., R, 2**n)``."""
        if self.gather is not None:
            self.gather.assign(state, self.gather.apply(state))  # a Pauli is its own inverse
            return
        n = int(state.shape[-1]).bit_length() - 1
        tensor = state.reshape(state.shape[:-1] + (2,) * n)
        k = len(self.qubits)
        assert self.matrix is not None  # a Fixed without a gather has its matrix
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
        elif name in ("p", "u1"):
            self.rotation({}, -1.0, params[0], (qubits[0],), name)
        elif name in ("cp", "cu1"):
            self.rotation({}, -1.0, params[0], tuple(qubits), name)
        elif name in ("rbs", "fbs"):
            i, j, inner = qubits[0], qubits[-1], qubits[1:-1]
            zs = {q: "Z" for q in inner}
            self.rotation({i: "X", j: "Y", **zs}, 0.5, params[0], (), name)
            self.rotation({i: "Y", j: "X", **zs}, -0.5, params[0], (), name)
        elif name in ("u", "u3"):  # U(t, f, l) = RZ(f) RY(t) RZ(l) up to a global phase
            q = qubits[0]
            self.rotation({q: "Z"}, 0.5, params[2], (), name)
            self.rotation({q: "Y"}, 0.5, params[0], (), name)
            self.rotation({q: "Z"}, 0.5, params[1], (), name)
        elif name == "PauliEvolution":
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
