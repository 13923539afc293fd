"""The exact noisy distribution of a circuit: the compiled program behind
:mod:`qdensity.execution.samplers.noisy_exact` (see there for what it computes and why).

Blocks of gates on at most two qubits, each gate followed by its error, are fused into one
superoperator ``S`` acting on ``rho`` flattened as ``rho[l, m] -> l * d + m`` (``l``, ``m``
local indices, Qiskit's little-endian order on the block's qubits); a unitary contributes
``U (x) conj(U)``, an error ``sum_K K (x) conj(K)`` of its Kraus operators. The kernel that
applies a block to every row is in :mod:`._noisy_kernels`.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import ParameterExpression, QuantumCircuit

from qdensity.analysis.gate_registry import GATES
from qdensity.execution._compile import circuit_digest
from qdensity.execution.samplers._noise_tables import NoiseTables
from qdensity.execution.samplers._noisy_kernels import apply_superop

__all__ = ["MAX_QUBITS", "supported", "exact_probabilities", "Program",
           "active_count"]

#: Widest circuit (active qubits) simulated here: a density matrix of ``16 * 4**a`` bytes a row.
MAX_QUBITS = 10

_SKIP = frozenset({"barrier"})
_REFUSED = frozenset({"reset", "delay", "initialize", "if_else", "while_loop", "for_loop",
                      "switch_case", "box", "store"})


def _embed(mat: np.ndarray, where: int) -> np.ndarray:
    """A one-qubit operator (..., 2, 2) on local qubit ``where`` of a two-qubit block."""
    eye = np.eye(2)
    if mat.ndim == 2:
        return np.kron(eye, mat) if where == 0 else np.kron(mat, eye)
    return (np.einsum("ij,rkl->rikjl", eye, mat) if where == 0
            else np.einsum("rij,kl->rikjl", mat, eye)).reshape(mat.shape[0], 4, 4)


def _embed_superop(sup: np.ndarray, where: int) -> np.ndarray:
    """A one-qubit superoperator (4, 4) on local qubit ``where`` of a two-qubit block (16, 16)."""
    t = sup.reshape(2, 2, 2, 2)  # [l', m', l, m]
    eye = np.eye(2)
    if where == 0:  # local index l = b0 + 2 b1: the block qubit 1 is untouched
        full = np.einsum("ac,bd,iIjJ->aibIcjdJ", eye, eye, t)  # (b1', b0', m1', m0', ...)
    else:
        full = np.einsum("ac,bd,iIjJ->iaIbjcJd", eye, eye, t)
    return full.reshape(16, 16)


def _unitary_superop(U: np.ndarray) -> np.ndarray:
    """``U (x) conj(U)`` for ``U`` (d, d) or per row (R, d, d)."""
    if U.ndim == 2:
        return np.kron(U, np.conj(U))
    R, d, _ = U.shape
    return np.einsum("rij,rkl->rikjl", U, np.conj(U)).reshape(R, d * d, d * d)


def supported(circuit: QuantumCircuit, tables: NoiseTables) -> bool:
    """Whether :class:`ExactNoisySampler` computes ``circuit`` under ``tables`` (see module).

    Parameters
    ----------
    circuit : QuantumCircuit
    tables : NoiseTables

    Returns
    -------
    bool
        False for a mid-circuit measurement, ``reset``, ``delay``, classical control, a gate
        on more than two qubits or a noise model with an error not applied here.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.h(0)
    >>> _ = qc.measure_all()
    >>> supported(qc, NoiseTables(None))
    True
    >>> _ = qc.reset(0)
    >>> supported(qc, NoiseTables(None))
    False
    """
    if not tables.ok or circuit.num_vars or circuit.num_stretches:
        return False
    measured: set = set()
    for inst in circuit.data:
        name = inst.name
        if name in _SKIP:
            continue
        if name in _REFUSED or getattr(inst.operation, "condition", None) is not None:
            return False
        if name == "measure":
            if measured.intersection(inst.qubits):
                return False  # measured twice
            measured.update(inst.qubits)
            continue
        if inst.clbits or measured.intersection(inst.qubits) or len(inst.qubits) > 2:
            return False
        if not hasattr(inst.operation, "to_matrix") and not inst.operation.is_parameterized():
            return False
    return True


class Program:
    """A circuit compiled to fused blocks on its active qubits (see module)."""

    def __init__(self, circuit: QuantumCircuit, tables: NoiseTables):
        index = {q: i for i, q in enumerate(circuit.qubits)}
        active = sorted({index[q] for inst in circuit.data if inst.name not in _SKIP
                         for q in inst.qubits})
        self.num_active = len(active)
        local = {q: i for i, q in enumerate(active)}
        self.parameters = list(circuit.parameters)
        position = {p: i for i, p in enumerate(self.parameters)}
        self.measure: list[tuple[int, int]] = []  # (local qubit, clbit)
        blocks: list[dict | None] = []
        open_: dict[int, int] = {}
        for inst in circuit.data:
            if inst.name in _SKIP:
                continue
            phys = tuple(index[q] for q in inst.qubits)
            qs = tuple(local[q] for q in phys)
            if inst.name == "measure":
                err = tables.error("measure", phys)
                if err is not None:
                    self._add(blocks, open_, qs, ("fixed", qs, err))
                self.measure.append((qs[0], circuit.find_bit(inst.clbits[0]).index))
                continue
            op = inst.operation
            err = tables.error(inst.name, phys)
            if op.is_parameterized():
                self._add(blocks, open_, qs, ("param", qs, op, _affine(op.params, position), err))
            else:
                sup = _unitary_superop(np.asarray(op.to_matrix(), dtype=complex))
                if err is not None:
                    sup = err @ sup
                self._add(blocks, open_, qs, ("fixed", qs, sup))
        self.blocks = [self._finish(b) for b in blocks if b is not None]
        self.readout = [tables.readout_matrix(active[q]) for q, _ in self.measure]
        self.num_clbits = circuit.num_clbits
        self.cregs = [(r.name, [circuit.find_bit(b).index for b in r]) for r in circuit.cregs]
        # keys the circuit's stream of draws (noisy_exact): its instructions, not its name,
        # which Qiskit numbers by the circuits made before it
        self.fingerprint = int.from_bytes(circuit_digest(circuit), "little")

    @staticmethod
    def _add(blocks, open_, qs, item) -> None:
        if len(qs) == 1:
            b = open_.get(qs[0])
            if b is not None:
                blocks[b]["items"].append(item)
                return
            blocks.append({"qubits": qs, "items": [item]})
            open_[qs[0]] = len(blocks) - 1
            return
        a, c = qs
        ba, bc = open_.get(a), open_.get(c)
        if ba is not None and ba == bc:
            blocks[ba]["items"].append(item)
            return
        items: list = []
        for b in (ba, bc):  # single-qubit blocks still open on a or c join the new block
            if b is not None and len(blocks[b]["qubits"]) == 1:
                items += blocks[b]["items"]
                blocks[b] = None
        blocks.append({"qubits": (a, c), "items": items + [item]})
        open_[a] = open_[c] = len(blocks) - 1

    @staticmethod
    def _finish(block: dict) -> dict:
        qs = block["qubits"]
        fixed = None  # the product of the fixed items before the first parametrised one
        steps: list = []  # per-row work: ("param", ...) or ("fixed", superop)
        for item in block["items"]:
            if item[0] == "fixed":
                sup = item[2] if len(qs) == 1 else (
                    item[2] if len(item[1]) == 2 and item[1] == qs else
                    _swap_superop(item[2]) if len(item[1]) == 2 else
                    _embed_superop(item[2], qs.index(item[1][0])))
                if steps:
                    steps.append(("fixed", sup))
                else:
                    fixed = sup if fixed is None else sup @ fixed
            else:
                _, iq, op, aff, err = item
                if err is not None:
                    err = (err if len(qs) == 1 or (len(iq) == 2 and iq == qs) else
                           _swap_superop(err) if len(iq) == 2 else
                           _embed_superop(err, qs.index(iq[0])))
                steps.append(_fourier(("param", iq, op, aff, err), qs))
        # fold runs of fixed steps after the first parametrised one
        folded: list = []
        for s in steps:
            if s[0] == "fixed" and folded and folded[-1][0] == "fixed":
                folded[-1] = ("fixed", s[1] @ folded[-1][1])
            else:
                folded.append(s)
        return {"qubits": qs, "fixed": fixed, "steps": folded}


def _swap_superop(sup: np.ndarray) -> np.ndarray:
    """A two-qubit superoperator given on ``(q1, q0)`` as one on ``(q0, q1)``."""
    t = sup.reshape([2] * 8)  # [l1', l0', m1', m0', l1, l0, m1, m0]
    return t.transpose(1, 0, 3, 2, 5, 4, 7, 6).reshape(16, 16)


def _affine(params, position) -> list:
    """Each gate parameter as ``(offset, [(column, coefficient), ...])`` when affine in the
    circuit's parameters, else the expression itself (bound per row)."""
    out: list = []
    for p in params:
        if not isinstance(p, ParameterExpression):
            out.append((float(p), []))
            continue
        terms = []
        try:
            for q in p.parameters:
                g = p.gradient(q)
                if isinstance(g, ParameterExpression):
                    raise TypeError("not affine")
                terms.append((position[q], float(np.real(complex(g)))))
            offset = float(np.real(complex(p.bind({q: 0.0 for q in p.parameters}))))
        except (TypeError, ValueError):
            out.append(p)
            continue
        out.append((offset, terms))
    return out


def _row_params(aff: list, values: np.ndarray, parameters) -> np.ndarray:
    """Gate parameters per row (R, k) from the circuit's parameter rows ``values`` (R, P)."""
    R = values.shape[0]
    cols = []
    for a in aff:
        if isinstance(a, tuple):
            offset, terms = a
            col = np.full(R, offset)
            for j, c in terms:
                col = col + c * values[:, j]
        else:
            col = np.array([float(a.bind({p: v[parameters.index(p)] for p in a.parameters}))
                            for v in values])
        cols.append(col)
    return np.stack(cols, axis=1) if cols else np.zeros((R, 0))


def _gate_matrices(op, angles: np.ndarray) -> np.ndarray:
    """The gate's matrix per row (R, d, d) for per-row parameters ``angles`` (R, k)."""
    kind = GATES.get(op.name)
    if kind is not None and kind.block is not None and angles.shape[1] == len(op.params) \
            and angles.shape[1]:
        return np.asarray(kind.block(*angles.T), dtype=complex)  # vectorised over the rows
    mats = []
    for row in angles:
        bound = op.copy()
        bound.params = [float(x) for x in row]
        mats.append(np.asarray(bound.to_matrix(), dtype=complex))
    return np.stack(mats)


def _step_superop(step: tuple, qs: tuple[int, ...], angles: np.ndarray) -> np.ndarray:
    """A parametrised step's superoperator per row (R, 4**k, 4**k) on its block's qubits
    ``qs``, its error included, for the gate parameters ``angles`` (R, p)."""
    _, iq, op, _, err = step
    R = angles.shape[0]
    U = _gate_matrices(op, angles)
    if len(qs) == 2 and len(iq) == 1:
        U = _embed(U, qs.index(iq[0]))
    elif len(iq) == 2 and iq != qs:
        U = U.reshape(R, 2, 2, 2, 2).transpose(0, 2, 1, 4, 3).reshape(R, 4, 4)
    s = _unitary_superop(U)
    return s if err is None else err @ s


def _fourier(step: tuple, qs: tuple[int, ...]) -> tuple:
    """``("fourier", A0, A1, Am1, affine)`` for a one-parameter step whose superoperator is
    ``A0 + A1 e^{i t} + Am1 e^{-i t}`` in its angle ``t`` (every rotation ``exp(-i t G / 2)``
    with ``G**2 = 1``: rz, ry, rx, rzz, ...; the three terms from three angles, the form
    checked at two more); the step as given otherwise. Rows then cost three array operations,
    not a gate matrix, two Kronecker products and a matrix product each."""
    op, aff = step[2], step[3]
    if len(op.params) != 1 or not isinstance(aff[0], tuple):
        return step
    t = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    try:
        S = _step_superop(step, qs, t[:, None])
    except Exception:  # noqa: BLE001 - a gate without a matrix here: keep the general path
        return step
    z = np.exp(1j * t)[:, None, None]
    terms = (S.mean(axis=0), (S * np.conj(z)).mean(axis=0), (S * z).mean(axis=0))
    check = np.array([0.7317, 2.2])
    zc = np.exp(1j * check)[:, None, None]
    if not np.allclose(terms[0] + terms[1] * zc + terms[2] * np.conj(zc),
                       _step_superop(step, qs, check[:, None]), atol=1e-12, rtol=0):
        return step
    return ("fourier", *terms, aff)


def _block_superop(block: dict, program: Program, values: np.ndarray) -> np.ndarray | None:
    """A block's superoperator: (4**k, 4**k) when it has no parameter, else one per row of
    ``values`` (R, 4**k, 4**k); None for an empty block."""
    qs = block["qubits"]
    sup = block["fixed"]
    for step in block["steps"]:
        if step[0] == "fixed":
            sup = step[1] if sup is None else step[1] @ sup
            continue
        angles = _row_params(step[-1] if step[0] == "fourier" else step[3], values,
                             program.parameters)
        if step[0] == "fourier":
            z = np.exp(1j * angles[:, 0])[:, None, None]
            s = step[1] + step[2] * z + step[3] * np.conj(z)
        else:
            s = _step_superop(step, qs, angles)
        sup = s if sup is None else s @ sup
    return sup


def exact_probabilities(program: Program, values: np.ndarray) -> np.ndarray:
    """Outcome probabilities of the measured qubits per row, readout errors applied.

    Parameters
    ----------
    program : Program
        The compiled circuit (``Program(circuit, tables)``).
    values : numpy.ndarray, shape (R, P)
        One row of the program's ``P`` parameter values per distribution (``P = 0``: an
        unparametrised circuit, ``R`` copies of its distribution).

    Returns
    -------
    numpy.ndarray, shape (R, 2**m)
        Outcome ``o`` has bit ``i`` = the ``i``-th measurement's result.

    Examples
    --------
    >>> import numpy as np
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.circuit import Parameter
    >>> qc = QuantumCircuit(1)
    >>> _ = qc.ry(Parameter("t"), 0)
    >>> _ = qc.measure_all()
    >>> probs = exact_probabilities(Program(qc, NoiseTables(None)), np.array([[0.0], [np.pi]]))
    >>> np.round(probs, 12).tolist()  # cos^2(t/2), sin^2(t/2)
    [[1.0, 0.0], [0.0, 1.0]]
    """
    a = program.num_active
    R = values.shape[0]
    if R == 0:
        return np.zeros((0, 2 ** len(program.measure)))
    # rows that agree on every parameter so far share one density matrix (a parameter-shift
    # PUB's rows differ from one gate on): states[owner[r]] is row r's
    owner = np.zeros(R, dtype=np.int64)
    states = np.zeros((1, 2**a, 2**a), dtype=complex)
    states[0, 0, 0] = 1.0
    for block in program.blocks:
        block_values = values  # the parameter rows of the states, in their order
        if any(step[0] != "fixed" for step in block["steps"]):
            if states.shape[0] < R:  # rows that share a state may still share after it
                key = np.concatenate([owner[:, None].astype(float)] + [
                    _row_params(step[-1] if step[0] == "fourier" else step[3], values,
                                program.parameters)
                    for step in block["steps"] if step[0] != "fixed"], axis=1)
                _, first, inverse = np.unique(key, axis=0, return_index=True,
                                              return_inverse=True)
                states = states[owner[first]]
                owner = inverse.reshape(-1)
                block_values = values[first]
            else:  # every row has its own state: owner is a permutation
                row_of = np.empty(R, dtype=np.int64)
                row_of[owner] = np.arange(R)
                block_values = values[row_of]
        sup = _block_superop(block, program, block_values)
        if sup is not None:
            states = apply_superop(states, sup, block["qubits"], a)
    diag = np.clip(np.real(np.einsum("rii->ri", states)), 0.0, None)[owner]
    m = len(program.measure)
    probs = diag.reshape((R,) + (2,) * a)
    keep = [1 + (a - 1 - q) for q, _ in program.measure]  # measurement i -> axis
    drop = tuple(ax for ax in range(1, a + 1) if ax not in keep)
    marg = probs.sum(axis=drop) if drop else probs
    # axes of marg follow sorted(keep); put measurement i's bit at position i (LSB first)
    order = sorted(keep)
    marg = np.moveaxis(marg, [1 + order.index(k) for k in reversed(keep)], list(range(1, m + 1)))
    for i, P in enumerate(program.readout):
        if P is None:
            continue
        axis = m - i  # measurement i is bit i: axis counted from the end
        marg = np.moveaxis(np.tensordot(marg, P, axes=([axis], [0])), -1, axis)
    out = marg.reshape(R, 2**m)
    return out / out.sum(axis=1, keepdims=True)


def active_count(circuit: QuantumCircuit) -> int:
    """Qubits an instruction other than ``barrier`` acts on."""
    return len({q for inst in circuit.data if inst.name not in _SKIP for q in inst.qubits})
