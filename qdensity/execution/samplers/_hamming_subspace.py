"""Amplitudes on the Hamming-weight-k subspace: index tables built once, gates applied to all
rows at once.

The subspace of ``n`` qubits with ``k`` ones has dimension ``D = C(n, k)``; its basis states
are the ``k``-subsets of the qubits in colexicographic order, state ``s`` with sorted qubits
``p_0 < ... < p_{k-1}`` at rank ``sum_i C(p_i, i + 1)``. A gate on ``m`` qubits that commutes
with the number operator is block diagonal by the weight ``w`` of its local bits; on the
subspace it mixes, for each assignment of the other qubits, the ``C(m, w)`` states that differ
only in the gate's qubits (:func:`block_table`). A gate's amplitude update is then one gather,
one batched ``(rows, groups, c) x (rows, c, c)`` product and one scatter: no Python work per row.
The ``w = 0`` block (a phase of the untouched states) is divided out of the others, which only
changes a global phase per row.
"""

from __future__ import annotations

import math

import numpy as np

from qdensity.analysis.gate_registry import FBS, GATES
from qdensity.execution.samplers._hamming_compile import GateOp, HammingTemplate


def subsets(n: int, k: int) -> np.ndarray:
    """The ``k``-subsets of ``range(n)`` in colex order, shape ``(C(n, k), k)``, sorted rows."""
    table = np.zeros((1, 0), dtype=np.int32)  # subsets of size 0 of range(m), for m = 0
    for size in range(1, k + 1):
        # subsets of `size` with largest element top: (subsets of size-1 of range(top)) + top
        parts = []
        for top in range(size - 1, n):
            # in colex order the subsets of range(top) come first
            head = table[: math.comb(top, size - 1)]
            parts.append(np.column_stack([head, np.full(head.shape[0], top, dtype=np.int32)]))
        table = np.concatenate(parts) if parts else np.zeros((0, size), dtype=np.int32)
    return table


def ranks(positions: np.ndarray, binom: np.ndarray) -> np.ndarray:
    """Colex rank of each row of sorted qubit positions, shape (N, k) -> (N,)."""
    k = positions.shape[1]
    out = np.zeros(positions.shape[0], dtype=np.int64)
    for i in range(k):
        out += binom[positions[:, i], i + 1]
    return out


def binomials(n: int, k: int) -> np.ndarray:
    """``C(a, b)`` for ``a <= n``, ``b <= k``, shape (n + 1, k + 1), int64."""
    out = np.zeros((n + 1, k + 1), dtype=np.int64)
    for a in range(n + 1):
        for b in range(min(a, k) + 1):
            out[a, b] = math.comb(a, b)
    return out


class Subspace:
    """The weight-``k`` subspace of ``n`` qubits with its basis (``states``) and rank table."""

    def __init__(self, n: int, k: int):
        self.n, self.k = n, k
        self.states = subsets(n, k)  # (D, k)
        self.binom = binomials(n, k)
        self.dimension = self.states.shape[0]
        self._occ: dict[int, np.ndarray] = {}

    def occupied(self, q: int) -> np.ndarray:
        """Boolean mask (D,) of the states in which qubit ``q`` is 1."""
        if q not in self._occ:
            self._occ[q] = np.any(self.states == q, axis=1)
        return self._occ[q]

    def rank_of(self, occupied: tuple) -> int:
        """Index of the basis state whose ones are ``occupied``."""
        return int(ranks(np.array([sorted(occupied)], dtype=np.int32), self.binom)[0])

    def block_table(self, qubits: tuple) -> list[tuple[np.ndarray, np.ndarray]]:
        """For each local weight ``w`` in ``1..m``: ``(configs, table)``, ``configs`` the local
        indices (little-endian on ``qubits``) of weight ``w``, ``table`` of shape
        ``(groups, len(configs))`` the subspace index of each group's member per config."""
        m = len(qubits)
        local = np.zeros(self.dimension, dtype=np.int64)
        for j, q in enumerate(qubits):
            local |= self.occupied(q).astype(np.int64) << j
        q_arr = np.asarray(qubits, dtype=np.int32)
        out = []
        for w in range(1, m + 1):
            configs = np.array([c for c in range(2**m) if bin(c).count("1") == w])
            if w > self.k:
                break
            base = np.flatnonzero(local == configs[0])
            if base.size == 0:
                out.append((configs, np.zeros((0, configs.size), dtype=np.int64)))
                continue
            rest = self.states[base]
            keep = ~np.isin(rest, q_arr)
            rest = rest[keep].reshape(base.size, self.k - w)
            table = np.empty((base.size, configs.size), dtype=np.int64)
            for col, c in enumerate(configs):
                chosen = q_arr[[(c >> j) & 1 == 1 for j in range(m)]]
                pos = np.sort(np.concatenate(
                    [rest, np.broadcast_to(chosen, (base.size, w))], axis=1), axis=1)
                table[:, col] = ranks(pos, self.binom)
            out.append((configs, table))
        return out

    def fbs_table(self, qubits: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(first, last, sign)``: pairs of states with the FBS gate's first (resp. last)
        qubit set and the other not, and ``(-1)^parity`` of the inner qubits per pair."""
        first, last = qubits[0], qubits[-1]
        a = np.flatnonzero(self.occupied(first) & ~self.occupied(last))
        rest = self.states[a]
        pos = np.sort(np.where(rest == first, last, rest), axis=1)
        b = ranks(pos, self.binom)
        parity = np.zeros(a.size, dtype=np.int64)
        for q in qubits[1:-1]:
            parity += self.occupied(q)[a]
        return a, b, np.where(parity % 2 == 0, 1.0, -1.0)


def local_matrix(gate: GateOp, values: np.ndarray) -> np.ndarray:
    """The gate's local matrix for parameter rows ``values`` (B, P): shape (B or 1, 2**m, 2**m),
    little-endian on ``gate.qubits``."""
    if gate.matrix is not None:
        return gate.matrix[None]
    if gate.operation is not None:
        qc, cols = gate.operation
        from qiskit.quantum_info import Operator

        return np.stack([Operator(qc.assign_parameters(
            dict(zip(qc.parameters, values[r, cols].tolist(), strict=True)))).data
            for r in range(values.shape[0])])
    t = [np.asarray(a.evaluate(values)) for a in gate.angles]
    kind = GATES.get(gate.name)
    if kind is None or kind.block is None:  # pragma: no cover - the compiler lists these only
        raise ValueError(f"no block for gate {gate.name!r}")
    return kind.block(*t)

class CompiledGate:
    """A gate's tables on one subspace (built once per template)."""

    def __init__(self, gate: GateOp, space: Subspace):
        self.gate = gate
        self.fbs: tuple[np.ndarray, np.ndarray, np.ndarray] | None
        if GATES.get(gate.name) is FBS:
            self.fbs = space.fbs_table(gate.qubits)
            self.blocks = None
        else:
            self.fbs = None
            self.blocks = space.block_table(gate.qubits)

    def apply(self, psi: np.ndarray, values: np.ndarray) -> None:
        """Apply the gate in place to amplitudes ``psi`` (B, D) for parameter rows (B, P)."""
        if self.fbs is not None:
            a, b, sign = self.fbs
            theta = self.gate.angles[0].evaluate(values)[:, None]
            c, s = np.cos(theta), np.sin(theta) * sign[None, :]
            pa, pb = psi[:, a], psi[:, b]
            psi[:, a] = c * pa - s * pb
            psi[:, b] = s * pa + c * pb
            return
        mat = local_matrix(self.gate, values)
        mat = mat / mat[:, :1, :1]  # the untouched states' phase divided out
        if psi.dtype.kind != "c":
            mat = mat.real
        assert self.blocks is not None  # every gate but FBS has its blocks
        for configs, table in self.blocks:
            if table.shape[0] == 0:
                continue
            block = mat[:, configs][:, :, configs]  # (B', c, c)
            amp = psi[:, table]  # (B, G, c)
            psi[:, table] = amp @ np.swapaxes(block, 1, 2)


class SubspaceProgram:
    """A template compiled on its subspace: the input state and every gate's tables."""

    def __init__(self, template: HammingTemplate):
        self.template = template
        self.space = Subspace(template.num_qubits, template.weight)
        self.start = self.space.rank_of(template.occupied)
        self.gates = [CompiledGate(g, self.space) for g in template.gates]
        self.dtype = float if template.real else complex

    def probabilities(self, values: np.ndarray) -> np.ndarray:
        """Outcome probabilities over the subspace, shape (B, D), for rows (B, P)."""
        psi = np.zeros((values.shape[0], self.space.dimension), dtype=self.dtype)
        psi[:, self.start] = 1.0
        for g in self.gates:
            g.apply(psi, values)
        return psi.real**2 + psi.imag**2 if psi.dtype.kind == "c" else psi**2
