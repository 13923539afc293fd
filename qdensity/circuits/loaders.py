"""Unary amplitude loaders: vector, matrix and ``Load(sqrt(alpha))`` (paper Fig. 1, Supp. I).

A unary loader on ``d`` qubits prepares ``|x> = sum_j x_j / ||x|| |e_j>`` from ``|0...0>``,
where ``|e_j>`` has only qubit ``j`` set (amplitude ``y_j`` is statevector entry ``2**j``).
It is one ``X`` gate on a *start qubit* followed by ``d - 1`` RBS gates (paper eq. 8) arranged
as a binary tree over contiguous index ranges: an RBS splits the amplitude of a range between
its two halves (Johri et al. 2021, Cherrat et al. 2022). Three layouts of that tree:

=============  =================  ===============  ==========================================
layout         RBS gates          RBS depth        shape
=============  =================  ===============  ==========================================
parallel       d - 1              ceil(log2 d)     balanced binary tree
diagonal       d - 1              d - 1            one nearest-neighbour chain 0 -> d-1
semi_diagonal  d - 1              ceil(d / 2)      two nearest-neighbour chains from the middle
=============  =================  ===============  ==========================================

Every RBS transpiles to 2 CZ (or CX), so a loader costs ``2 (d - 1)`` two-qubit gates. Any
length ``d >= 2`` is allowed (not only powers of two), and so are negative entries and zeros,
including whole sub-trees of zeros: every angle is an ``arctan2`` of two (signed) sub-norms,
so nothing is divided by zero.

The qubit that carries a range's amplitude (its *head*) is free in the parallel layout; it is
chosen by a small dynamic programme that minimises the total qubit distance ``sum |i - j|``
over the RBS gates, so that the tree is as nearest-neighbour-friendly as a fixed
"qubit ``j`` carries component ``j``" assignment allows (for ``d = 8`` the total distance is 9
instead of 12 for first-index heads).

For datasets, :func:`unary_loader_template` gives one parameterised circuit (angles in a
``ParameterVector`` named ``"x"``: they carry data) and :func:`loader_angles` maps a batch of
vectors to its parameter rows, vectorised over the batch; transpile the template once.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from qiskit.circuit import ParameterVector, QuantumCircuit, QuantumRegister

from qdensity.circuits.gates import RBSGate
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    MAX_DENSE_ENTRIES,
    Array,
    Instance,
    Options,
    Qubits,
    check_distribution,
    check_num_qubits,
    validates,
)

__all__ = [
    "LAYOUTS",
    "unary_loader",
    "unary_loader_template",
    "loader_angles",
    "loader_start_qubit",
    "matrix_loader",
    "distribution_loader",
]

#: Allowed values of the ``layout`` argument.
LAYOUTS = ("parallel", "diagonal", "semi_diagonal")


# --------------------------------------------------------------------------------------------
# The loader tree
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Node:
    """One RBS of a loader: splits range ``[lo, hi)`` at ``mid``.

    The incoming amplitude sits on ``src`` (the head of the range, inside one half); the RBS
    ``RBS(theta)`` on qubits ``[src, tgt]`` keeps ``cos(theta)`` of it on ``src`` and moves
    ``sin(theta)`` to ``tgt`` (the head of the other half).
    ``theta = arctan2(a(tgt half), a(src half))`` where ``a`` of a one-element range is the
    signed entry and of a longer range its Euclidean norm.
    """

    lo: int
    mid: int
    hi: int
    src: int
    tgt: int

    @property
    def src_range(self) -> tuple[int, int]:
        return (self.lo, self.mid) if self.src < self.mid else (self.mid, self.hi)

    @property
    def tgt_range(self) -> tuple[int, int]:
        return (self.mid, self.hi) if self.src < self.mid else (self.lo, self.mid)


@dataclass(frozen=True)
class _Plan:
    start: int
    nodes: tuple[_Node, ...]


def _check_layout(layout) -> str:
    if not isinstance(layout, str) or layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(map(repr, LAYOUTS))}, got {layout!r}")
    return layout


def _parallel_plan(d: int) -> _Plan:
    """Balanced tree; heads chosen to minimise the total qubit distance of the RBS gates."""
    # cost[(lo, hi)][h - lo]: least total distance of the sub-tree on [lo, hi) with head h.
    # partner[(lo, hi)][h - lo]: head of the other half when the range's head is h.
    cost: dict[tuple[int, int], np.ndarray] = {}
    partner: dict[tuple[int, int], np.ndarray] = {}

    def solve(lo: int, hi: int) -> None:
        if hi - lo == 1:
            cost[(lo, hi)] = np.zeros(1)
            partner[(lo, hi)] = np.full(1, -1)
            return
        mid = lo + (hi - lo + 1) // 2
        solve(lo, mid)
        solve(mid, hi)
        c_left, c_right = cost[(lo, mid)], cost[(mid, hi)]
        idx_left, idx_right = np.arange(lo, mid), np.arange(mid, hi)
        # Head h in the left half: partner h' in the right half, distance h' - h.
        k_right = int(np.argmin(c_right + idx_right))
        from_left = c_left - idx_left + (c_right + idx_right)[k_right]
        # Head h in the right half: partner h' in the left half, distance h - h'.
        k_left = int(np.argmin(c_left - idx_left))
        from_right = c_right + idx_right + (c_left - idx_left)[k_left]
        cost[(lo, hi)] = np.concatenate([from_left, from_right])
        partner[(lo, hi)] = np.concatenate(
            [np.full(mid - lo, mid + k_right), np.full(hi - mid, lo + k_left)]
        )

    solve(0, d)
    start = int(np.argmin(cost[(0, d)]))
    # Breadth-first so that gate order is layer order.
    nodes: list[_Node] = []
    frontier = [(0, d, start)]
    while frontier:
        nxt = []
        for lo, hi, head in frontier:
            if hi - lo == 1:
                continue
            mid = lo + (hi - lo + 1) // 2
            tgt = int(partner[(lo, hi)][head - lo])
            nodes.append(_Node(lo, mid, hi, head, tgt))
            if head < mid:
                nxt += [(lo, mid, head), (mid, hi, tgt)]
            else:
                nxt += [(lo, mid, tgt), (mid, hi, head)]
        frontier = nxt
    return _Plan(start, tuple(nodes))


def _diagonal_plan(d: int) -> _Plan:
    """Chain ``RBS(0, 1), RBS(1, 2), ...``: range ``[k, d)`` splits into ``{k}``, ``[k+1, d)``."""
    return _Plan(0, tuple(_Node(k, k + 1, d, k, k + 1) for k in range(d - 1)))


def _semi_diagonal_plan(d: int) -> _Plan:
    """Root on ``(m-1, m)``, ``m = d // 2``, then a chain down to 0 and one up to ``d - 1``."""
    m = d // 2
    nodes = [_Node(0, m, d, m - 1, m)]
    left = [_Node(0, k, k + 1, k, k - 1) for k in range(m - 1, 0, -1)]  # [0, k+1) -> [0,k), {k}
    right = [_Node(k, k + 1, d, k, k + 1) for k in range(m, d - 1)]  # [k, d) -> {k}, [k+1, d)
    for t in range(max(len(left), len(right))):
        nodes += [chain[t] for chain in (left, right) if t < len(chain)]
    return _Plan(m - 1, tuple(nodes))


@lru_cache(maxsize=256)
def _plan(d: int, layout: str) -> _Plan:
    if d == 1:
        return _Plan(0, ())
    if layout == "parallel":
        return _parallel_plan(d)
    if layout == "diagonal":
        return _diagonal_plan(d)
    return _semi_diagonal_plan(d)


def _range_amplitude(X: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Signed entry (length-1 range) or Euclidean norm of ``X[:, lo:hi]``; shape (B,)."""
    if hi - lo == 1:
        return X[:, lo]
    return np.linalg.norm(X[:, lo:hi], axis=1)


def _angles(X: np.ndarray, plan: _Plan) -> np.ndarray:
    """Angles of ``plan`` for the rows of ``X`` (shape (B, d)); shape (B, d - 1).

    Rows are first divided by their largest absolute entry (angles are scale invariant) so
    that sub-norms neither underflow nor overflow for tiny or huge inputs.
    """
    scale = np.max(np.abs(X), axis=1, keepdims=True)
    X = X / np.where(scale > 0, scale, 1.0)
    out = np.empty((X.shape[0], len(plan.nodes)))
    for k, node in enumerate(plan.nodes):
        out[:, k] = np.arctan2(
            _range_amplitude(X, *node.tgt_range), _range_amplitude(X, *node.src_range)
        )
    return out


def _append_rbs(qc: QuantumCircuit, qubits, plan: _Plan, angles, *, inverse: bool = False):
    """Append the RBS part of a loader (or its inverse) on ``qubits`` (register order)."""
    pairs = list(zip(plan.nodes, angles, strict=True))
    if inverse:
        for node, theta in reversed(pairs):
            qc.append(RBSGate(-theta), [qubits[node.src], qubits[node.tgt]])
    else:
        for node, theta in pairs:
            qc.append(RBSGate(theta), [qubits[node.src], qubits[node.tgt]])


# --------------------------------------------------------------------------------------------
# Public builders
# --------------------------------------------------------------------------------------------


def loader_start_qubit(d: int, layout: str = "parallel") -> int:
    """Qubit that receives the ``X`` gate in the unary loader of length ``d``.

    Parameters
    ----------
    d : int
        Vector length, ``>= 1`` (``d = 1`` gives qubit 0).
    layout : {"parallel", "diagonal", "semi_diagonal"}

    Returns
    -------
    int
        ``0`` for the diagonal layout, ``d // 2 - 1`` for the semi-diagonal one, and the root
        head chosen for nearest-neighbour friendliness for the parallel one.

    Examples
    --------
    >>> loader_start_qubit(8, "diagonal"), loader_start_qubit(8, "semi_diagonal")
    (0, 3)
    """
    d = check_num_qubits(d, "d", minimum=1)
    return _plan(d, _check_layout(layout)).start


@validates(d=Qubits(2), layout=Options(LAYOUTS), parameter_prefix=Instance(str))
def unary_loader_template(
    d: int, layout: str = "parallel", parameter_prefix: str = "x"
) -> QuantumCircuit:
    """Parameterised unary loader: one circuit to transpile once for a whole dataset.

    Parameters
    ----------
    d : int
        Vector length (number of qubits), ``>= 2``.
    layout : {"parallel", "diagonal", "semi_diagonal"}
        Shape of the RBS tree; RBS depth ``ceil(log2 d)``, ``d - 1`` or ``ceil(d / 2)``.
    parameter_prefix : str
        Name of the ``ParameterVector`` of the ``d - 1`` RBS angles (``"x"``: they carry data).

    Returns
    -------
    QuantumCircuit
        ``d`` qubits: ``X`` on :func:`loader_start_qubit`, then ``d - 1`` RBS gates whose
        angles are the vector's elements in gate (= ``circuit.parameters``) order. Bind them
        with :func:`loader_angles`.

    Examples
    --------
    >>> import numpy as np
    >>> tpl = unary_loader_template(5, "semi_diagonal")
    >>> tpl.num_parameters
    4
    >>> qc = tpl.assign_parameters(loader_angles(np.array([1.0, -2.0, 0.0, 0.5, 3.0]),
    ...                                          "semi_diagonal"))
    """
    d = int(d)
    if not parameter_prefix:
        raise ValueError(f"parameter_prefix must be a non-empty str, got {parameter_prefix!r}")
    plan = _plan(d, layout)
    theta = ParameterVector(parameter_prefix, d - 1)
    qc = QuantumCircuit(d, name=f"unary_loader_{layout}")
    qc.x(plan.start)
    _append_rbs(qc, list(range(d)), plan, list(theta))
    return qc


@validates(X=Array(ndim=(1, 2), max_size=MAX_DENSE_ENTRIES), layout=Options(LAYOUTS))
def loader_angles(X, layout: str = "parallel") -> np.ndarray:
    """RBS angles of the unary loader for one vector or a batch (vectorised over the batch).

    The angle of an RBS splitting a range into halves ``S`` (holding the amplitude) and ``T``
    is ``arctan2(a(T), a(S))``, ``a`` the signed entry of a one-element half or the norm of a
    longer one. Angles are scale invariant: the vector is normalised by the circuit, not here.

    Parameters
    ----------
    X : array_like, shape (B, d) or (d,)
        Real, finite, ``d >= 2``; no row may be the zero vector.
    layout : {"parallel", "diagonal", "semi_diagonal"}

    Returns
    -------
    numpy.ndarray, shape (B, d - 1) or (d - 1,)
        In ``unary_loader_template(d, layout).parameters`` order.

    Examples
    --------
    >>> loader_angles([[1.0, 0.0], [0.0, -1.0]], "diagonal").round(4).tolist()
    [[0.0], [-1.5708]]
    """
    arr = np.asarray(X, dtype=float)
    batch = arr.reshape(1, -1) if arr.ndim == 1 else arr
    if batch.shape[1] < 2:
        raise ValueError(f"X must have d >= 2 columns (vector length), got shape {arr.shape}")
    zero_rows = np.flatnonzero(~np.any(batch != 0, axis=1))
    if zero_rows.size:
        raise ValueError(
            f"X must not contain zero vectors (they cannot be normalised); zero rows: "
            f"{zero_rows.tolist()}"
        )
    out = _angles(batch, _plan(batch.shape[1], layout))
    return out[0] if arr.ndim == 1 else out


@validates(x=Array(ndim=1, min_size=2, max_size=MAX_CIRCUIT_QUBITS), layout=Options(LAYOUTS))
def unary_loader(x, layout: str = "parallel") -> QuantumCircuit:
    """Unary amplitude loader ``|0...0> -> sum_j x_j / ||x|| |e_j>`` (paper Fig. 1, Johri 2021).

    Parameters
    ----------
    x : array_like, shape (d,)
        Real, finite, not all zero, ``d >= 2``. Negative entries and zeros are allowed.
    layout : {"parallel", "diagonal", "semi_diagonal"}
        ``"parallel"``: balanced tree, RBS depth ``ceil(log2 d)``; ``"diagonal"``: a chain,
        depth ``d - 1``; ``"semi_diagonal"``: two chains from the middle, depth ``ceil(d/2)``.

    Returns
    -------
    QuantumCircuit
        ``d`` qubits, one ``X`` and ``d - 1`` RBS gates (``2 (d - 1)`` CZ after transpiling).
        Equal to ``unary_loader_template(d, layout).assign_parameters(loader_angles(x,
        layout))``.

    Examples
    --------
    >>> from qiskit.quantum_info import Statevector
    >>> qc = unary_loader([3.0, 0.0, -4.0], "parallel")
    >>> sv = Statevector(qc).data.real
    >>> [round(float(sv[2**j]), 6) for j in range(3)]
    [0.6, 0.0, -0.8]
    """
    arr = np.asarray(x, dtype=float)
    if not np.any(arr):
        raise ValueError("x must not be the zero vector (it cannot be normalised)")
    plan = _plan(arr.size, layout)
    qc = QuantumCircuit(arr.size, name=f"unary_loader_{layout}")
    qc.x(plan.start)
    _append_rbs(qc, list(range(arr.size)), plan, _angles(arr[None, :], plan)[0].tolist())
    return qc


@validates(X=Array(ndim=2, max_size=MAX_DENSE_ENTRIES), layout=Options(LAYOUTS))
def matrix_loader(X, layout: str = "parallel") -> QuantumCircuit:
    """Matrix loader ``|0> -> sum_ij X_ij |e_i>_row |e_j>_col / ||X||_F`` (Supp. I.2, I.3).

    Construction (Cherrat et al. 2022, without controlled RBS gates): load the row norms
    ``(||X_1||, ..., ||X_n||)`` on ``row`` with a unary loader; then for each non-zero row
    ``i``, with ``R_i`` the RBS part of the unary loader of ``X_i`` on ``col`` (loader
    ``= R_i X_s``, ``s`` the start qubit), apply ``R_i^dagger``, ``CNOT(row_i -> col_s)``,
    ``R_i``. Branches ``k != i`` are unchanged: already-loaded ones see ``R_i R_i^dagger = I``,
    unloaded ones are ``|0...0>`` on ``col``, which the Hamming-weight-preserving ``R_i^dagger``
    leaves alone. ``R_i^dagger`` of the first loaded row is omitted (it acts on ``|0...0>``
    only); all-zero rows are skipped (their branch has amplitude 0).

    Gate counts, with ``m`` the number of non-zero rows: ``1`` X,
    ``(n - 1) + (2 m - 1)(d - 1)`` RBS and ``m`` CNOT, i.e.
    ``2 (n - 1) + 2 (2 m - 1)(d - 1) + m`` two-qubit gates after transpiling. RBS depth at most
    ``depth_row + (2 m - 1) depth_col`` with the depths of the chosen layout.

    Parameters
    ----------
    X : array_like, shape (n, d)
        Real, finite, not all zero; ``n >= 1``, ``d >= 1``. Zero rows and entries allowed.
    layout : {"parallel", "diagonal", "semi_diagonal"}
        Layout of every unary loader (row register and column loaders).

    Returns
    -------
    QuantumCircuit
        Registers ``row`` (``n`` qubits, qubits ``0 .. n-1``) and ``col`` (``d`` qubits);
        amplitude of ``|e_i>_row |e_j>_col`` is statevector entry ``2**i + 2**(n + j)``.

    Examples
    --------
    >>> qc = matrix_loader([[1.0, 2.0, 0.0], [0.0, 0.0, 0.0], [-1.0, 0.5, 3.0]])
    >>> [reg.name for reg in qc.qregs], qc.num_qubits
    (['row', 'col'], 6)
    """
    arr = np.asarray(X, dtype=float)
    if not np.any(arr):
        raise ValueError("X must not be the zero matrix (it cannot be normalised)")
    n, d = arr.shape
    row, col = QuantumRegister(n, "row"), QuantumRegister(d, "col")
    qc = QuantumCircuit(row, col, name=f"matrix_loader_{layout}")

    row_plan = _plan(n, layout)
    arr = arr / np.max(np.abs(arr))  # scale invariant; keeps the row norms finite
    norms = np.linalg.norm(arr, axis=1)
    # With one column there are no column RBS gates to carry signs: load the signed column.
    row_amplitudes = arr[:, 0] if d == 1 else norms
    qc.x(row[row_plan.start])
    _append_rbs(qc, row, row_plan, _angles(row_amplitudes[None, :], row_plan)[0].tolist())

    col_plan = _plan(d, layout)
    nonzero = np.flatnonzero(norms > 0)
    all_angles = _angles(arr[nonzero], col_plan)
    for k, (i, angles) in enumerate(zip(nonzero, all_angles, strict=True)):
        angles = angles.tolist()
        if k > 0:
            _append_rbs(qc, col, col_plan, angles, inverse=True)
        qc.cx(row[int(i)], col[col_plan.start])
        _append_rbs(qc, col, col_plan, angles)
    return qc


@validates(alpha=Array(ndim=1, max_size=MAX_CIRCUIT_QUBITS), layout=Options(LAYOUTS))
def distribution_loader(alpha, layout: str = "parallel") -> QuantumCircuit:
    """``Load(sqrt(alpha))`` of Fig. 1 (register A): ``|0...0> -> sum_k sqrt(alpha_k) |e_k>``.

    Parameters
    ----------
    alpha : array_like, shape (K,)
        A probability vector (non-negative, summing to 1 within ``1e-9``; never renormalised).
        ``K = 1`` gives a single ``X`` gate.
    layout : {"parallel", "diagonal", "semi_diagonal"}
        ``"parallel"`` (the paper's choice) has RBS depth ``ceil(log2 K)``.

    Returns
    -------
    QuantumCircuit
        ``K`` qubits, named ``"load_sqrt_alpha"``; amplitude ``sqrt(alpha_k)`` at statevector
        entry ``2**k``.

    Examples
    --------
    >>> qc = distribution_loader([0.5, 0.25, 0.25])
    >>> qc.name, qc.num_qubits
    ('load_sqrt_alpha', 3)
    """
    arr = check_distribution(alpha, "alpha")
    amplitudes = np.sqrt(arr)
    plan = _plan(arr.size, layout)
    qc = QuantumCircuit(arr.size, name="load_sqrt_alpha")
    qc.x(plan.start)
    _append_rbs(qc, list(range(arr.size)), plan, _angles(amplitudes[None, :], plan)[0].tolist())
    return qc
