"""Compiled statevector kernels of the adjoint engine (numba).

A compiled :class:`._program.Program` becomes flat tables (one row per
operation) and two kernels (:mod:`._kernels_planar`) run the whole circuit per
parameter row, blocks of rows in threads (:mod:`qdensity.execution._threads`), every gate in
place on the row's state, held as
separate real and imaginary parts so that the loops vectorise:

* a (controlled) Pauli rotation ``exp(-i a c Pi P)`` or a fixed (controlled) Pauli string: one
  loop over the amplitude pairs ``(k, k ^ x)`` on the controlled positions (a diagonal string
  scales each amplitude), ``new_k = c psi_k + m f_k psi_{k ^ x}`` with ``c = cos``,
  ``m = -i sin`` (``+i sin`` to undo it; ``c = 0, m = 1`` for a fixed string) and
  ``f_k = phase (-1)^{|k & z|}``;
* a fixed gate on up to :data:`MAX_DENSE` qubits: its matrix on the ``2**k`` amplitudes that
  differ only on its qubits; consecutive fixed gates on one qubit are multiplied once at
  compile time (a fused run);
* the backward sweep of adjoint differentiation visits a rotation once: the derivative
  ``2 c Im <lam_m| Pi P |phi>`` of every observable and the undoing of the gate on ``phi`` and
  every ``lam_m`` happen in the same loop over amplitude pairs;
* from :data:`FUSE_MIN_QUBITS` qubits, runs of Pauli operations on at most :data:`FUSE_QUBITS`
  qubits are fused into blocks, each one pass over the state (:mod:`._kernels_fused`);
* a permutation of the amplitudes that moves qubits between bits (one pass through a buffer):
  from 10 qubits on, the circuit runs in a moving layout that keeps every gate off the four
  lowest bits, where blocks are too short to vectorise (:mod:`._layout`).

The pure-numpy path of :mod:`._program` computes the same numbers; it is
used when numba is missing or ``QDENSITY_NUMBA=0`` is set (tests run both).
"""

from __future__ import annotations

import numpy as np

from qdensity.cluster import idle_core
from qdensity.execution import _numba
from qdensity.execution._threads import num_threads, run_blocks, split

__all__ = ["Tables", "tables", "forward", "backward", "fuse_blocks", "MAX_DENSE",
           "FUSE_QUBITS", "FUSE_MIN_QUBITS"]

#: Widest fixed (dense) gate the kernels apply; a program with a wider one runs on numpy.
MAX_DENSE = 3
#: Most qubits of a fused block (:func:`fuse_blocks`): a tile of ``2**5 x 16`` amplitudes is
#: 8 KiB per state, so ``phi`` and one ``lam`` stay in the first-level cache.
FUSE_QUBITS = 5
#: Fewest gates in a block: loading and storing a tile costs about two gates' passes.
FUSE_MIN_GATES = 4
#: A fused circuit keeps its blocks only if it makes at most this fraction of the passes of
#: its gates one by one (its layout keeps more low bits free, so its permutations cost more).
FUSE_GAIN = 0.75
#: Narrower circuits run gate by gate (and so does any circuit narrower than
#: ``2 FUSE_LOW_BITS + FUSE_QUBITS``, whose layout cannot keep the low bits free).
FUSE_MIN_QUBITS = 17
#: Bits a fused circuit's layout keeps free of gates: a tile row is then ``2**6`` contiguous
#: amplitudes (:data:`._kernels_fused.LOG_V`), long enough for the vector loops.
FUSE_LOW_BITS = 6

class Tables:
    """A program as flat arrays for the kernels (see the module docstring).

    Attributes
    ----------
    kind : int64 (O,)
        0 rotation, 1 fixed Pauli string, 2 fixed dense gate, 3 a permutation of the bits (the
        moving layout of :mod:`qdensity.execution.statevector._layout`; masks and positions of every
        operation are in the layout current at it), 4 a fused block's header (its bits in
        ``pos``; its ``span`` member rows follow, see :func:`fuse_blocks`).
    xmask, zmask, cmask : int64 (O,)
    phase : complex128 (O,)
        The string's scalar ``(-i)^{#Y}``.
    scale : float64 (O,)
        Generator coefficient ``c`` of a rotation.
    rot : int64 (O,)
        Rotation index ``g`` (-1 for fixed gates; for a permutation, its table in ``ptab``,
        the inverse's at ``rot + 1``).
    pos, npos : int64 (O, W), (O,)
        Sorted bit positions skipped by the pair loop (controls and the lowest X, else Z, bit;
        a dense gate's qubits).
    offs : int64 (O, 2**MAX_DENSE)
        A dense gate's amplitude offsets; ``mat`` / ``inv`` complex128 (O, D, D) its matrix
        and inverse.
    ptab : int64 (2 x permutations, 2 + 2 D)
        A permutation as tiles (:func:`._layout.tile`): the mask of the bits
        that stay, the tile size ``D``, the entries' offsets and their sources.
    """

    def __init__(self, prog, fuse: bool = True):
        from qdensity.execution.statevector import _layout
        from qdensity.execution.statevector._program import Fixed, Rotation

        ops = _fuse(prog.ops)
        n = prog.num_qubits
        # fused only where the moving layout keeps every block off the FUSE_LOW_BITS lowest
        # bits (tile rows of 2**LOG_V amplitudes); with short rows a block costs more than
        # its gates one by one
        widest = max((bin(_touched(op)).count("1") for op in ops), default=0)
        fused = (fuse and n >= max(FUSE_MIN_QUBITS, _layout.MIN_QUBITS)
                 and n >= 2 * FUSE_LOW_BITS + max(FUSE_QUBITS, widest))
        items = fuse_blocks(ops, FUSE_QUBITS) if fused else list(range(len(ops)))
        masks = [_touched(ops[it]) if isinstance(it, int)
                 else _union(_touched(ops[j]) for j in it) for it in items]
        plan: list[tuple] = (_layout.plan(masks, n, FUSE_LOW_BITS if fused else None)
                             if n >= _layout.MIN_QUBITS
                             else [("op", i, tuple(range(n))) for i in range(len(items))])
        # ("perm", dest), ("op", op index, phys), ("block", mask, phys, members that follow)
        steps: list[tuple] = []
        for step in plan:
            if step[0] == "perm" or isinstance(items[step[1]], int):
                steps.append(step if step[0] == "perm" else ("op", items[step[1]], step[2]))
                continue
            steps.append(("block", masks[step[1]], step[2], len(items[step[1]])))
            steps.extend(("op", j, step[2]) for j in items[step[1]])
        O = len(steps)
        D = 2**MAX_DENSE
        self.kind = np.zeros(O, dtype=np.int64)
        self.xmask = np.zeros(O, dtype=np.int64)
        self.zmask = np.zeros(O, dtype=np.int64)
        self.cmask = np.zeros(O, dtype=np.int64)
        self.phase = np.ones(O, dtype=np.complex128)
        self.scale = np.zeros(O, dtype=np.float64)
        self.rot = np.full(O, -1, dtype=np.int64)
        self.pos = np.zeros((O, max(MAX_DENSE, n)), dtype=np.int64)
        self.npos = np.zeros(O, dtype=np.int64)
        self.offs = np.zeros((O, D), dtype=np.int64)
        self.mat = np.zeros((O, D, D), dtype=np.complex128)
        self.inv = np.zeros((O, D, D), dtype=np.complex128)
        perms = [_layout.tile(s[1]) for s in steps if s[0] == "perm"]
        width = max((p[1].size for p in perms), default=0)
        #: a permutation's row: free bits, tile size D, offsets (D), sources (D)
        self.ptab = np.zeros((2 * len(perms), 2 + 2 * width), dtype=np.int64)
        #: a block's header (kind 4): ``span`` member rows follow; members: ``head`` is the
        #: header's row (-1 elsewhere) and ``lx, lz, lc`` their masks in the block's local bits
        self.span = np.zeros(O, dtype=np.int64)
        self.head = np.full(O, -1, dtype=np.int64)
        self.lx = np.zeros(O, dtype=np.int64)
        self.lz = np.zeros(O, dtype=np.int64)
        self.lc = np.zeros(O, dtype=np.int64)
        self.tile = 1  # largest block's 2**k
        self.ok = True
        npm = 0
        # rotation g is the g-th in circuit order (its cos / sin column), wherever it runs
        rot_of = {id(op): g for g, op in enumerate(o for o in ops if isinstance(o, Rotation))}
        header, left, bits = -1, 0, [0]
        for i, step in enumerate(steps):
            if step[0] == "block":
                self.kind[i], self.span[i] = 4, step[3]
                header, left, bits = i, step[3], sorted(_bits(_moved(step[1], step[2])))
                self.pos[i, :len(bits)] = bits
                self.npos[i] = len(bits)
                self.tile = max(self.tile, 1 << len(bits))
                continue
            if step[0] == "op" and left:
                self.head[i] = header
                left -= 1
            if step[0] == "perm":  # kind 3: its row at rot[i], its inverse's at rot[i] + 1
                self.kind[i], self.rot[i] = 3, 2 * npm
                free, offs, src, back = perms[npm]
                D = offs.size
                for r, to in ((2 * npm, src), (2 * npm + 1, back)):
                    self.ptab[r, :2] = free, D
                    self.ptab[r, 2:2 + D] = offs
                    self.ptab[r, 2 + D:2 + 2 * D] = to
                npm += 1
                continue
            op, phys = ops[step[1]], step[2]
            gather = op.gather if isinstance(op, Rotation) else getattr(op, "gather", None)
            if gather is not None:
                self.kind[i] = 0 if isinstance(op, Rotation) else 1
                x, z, c = (_moved(m, phys) for m in (gather.xmask, gather.zmask, gather.cmask))
                self.xmask[i], self.zmask[i], self.cmask[i] = x, z, c
                if self.head[i] >= 0:
                    self.lx[i], self.lz[i], self.lc[i] = (_local_mask(m, bits)
                                                          for m in (x, z, c))
                self.phase[i] = gather.scalar
                skip = [q for q in range(n) if c >> q & 1]
                mask = int(x or z)
                if mask:  # the pair partner: the lowest X (else Z) bit, so no X or Z bit
                    skip.append((mask & -mask).bit_length() - 1)  # lies below a block
                skip.sort()
                self.pos[i, :len(skip)] = skip
                self.npos[i] = len(skip)
                if isinstance(op, Rotation):
                    self.scale[i], self.rot[i] = op.coefficient, rot_of[id(op)]
                continue
            assert isinstance(op, Fixed)
            k = len(op.qubits)
            if k > MAX_DENSE:
                self.ok = False
                continue
            qubits = [phys[q] for q in op.qubits]
            self.kind[i] = 2
            self.pos[i, :k] = sorted(qubits)
            self.npos[i] = k
            for a in range(2**k):
                self.offs[i, a] = sum(((a >> b) & 1) << q for b, q in enumerate(qubits))
            assert op.matrix is not None  # a Fixed without a gather has its matrix
            self.mat[i, :2**k, :2**k] = op.matrix
            self.inv[i, :2**k, :2**k] = op.matrix.conj().T
        self.num_rotations = len(rot_of)
        #: position of rotation g among the operations (blocks may run rotations out of order)
        self.rot_pos = np.zeros(self.num_rotations, dtype=np.int64)
        rows = np.flatnonzero(self.kind == 0)
        self.rot_pos[self.rot[rows]] = rows
        if not np.array_equal(np.sort(self.rot[rows]), np.arange(self.num_rotations)):
            raise AssertionError("a rotation lost or repeated")  # pragma: no cover

    def args(self):
        return (self.kind, self.xmask, self.zmask, self.cmask, self.phase, self.scale, self.rot,
                self.pos, self.npos, self.offs, self.mat, self.inv, self.ptab, self.span,
                self.head, self.lx, self.lz, self.lc, self.tile)


def _touched(op) -> int:
    """The logical qubits an operation touches, as a bit mask."""
    gather = getattr(op, "gather", None)
    if gather is not None:
        return int(gather.xmask | gather.zmask | gather.cmask)
    return sum(1 << q for q in op.qubits)


def _moved(mask: int, phys: tuple) -> int:
    """A logical qubit mask in the layout ``phys`` (qubit q at bit phys[q])."""
    out = 0
    q = 0
    while mask:
        if mask & 1:
            out |= 1 << phys[q]
        mask >>= 1
        q += 1
    return out


def _union(masks) -> int:
    out = 0
    for m in masks:
        out |= m
    return out


def _bits(mask: int) -> list[int]:
    return [b for b in range(mask.bit_length()) if mask >> b & 1]


def _local_mask(mask: int, bits: list[int]) -> int:
    """A physical bit mask in a block's local bits (bit ``j`` for ``bits[j]``)."""
    return sum(1 << j for j, b in enumerate(bits) if mask >> b & 1)


def fuse_blocks(ops: list, width: int) -> list:
    """Operations grouped into blocks of Pauli rotations and fixed Pauli strings on at most
    ``width`` qubits (and at least :data:`FUSE_MIN_GATES` gates), each block applied in one
    pass (:mod:`._kernels_fused`).

    Greedy over the circuit: a block starts at the first operation left and takes every later
    Pauli operation that keeps it within ``width`` qubits and touches no qubit of an operation
    passed over (an operation moves ahead only past operations on other qubits, which commute
    with it, so the product is unchanged). Dense fixed gates are never fused.

    Parameters
    ----------
    ops : list of Rotation or Fixed
    width : int

    Returns
    -------
    list
        In execution order: an operation's index, or a list of indices (a block of two or
        more, in circuit order).
    """
    masks = [_touched(op) for op in ops]
    pauli = [getattr(op, "gather", None) is not None for op in ops]
    full = _union(masks)
    left = list(range(len(ops)))
    out: list = []
    while left:
        first = left[0]
        if not pauli[first] or bin(masks[first]).count("1") > width:
            out.append(first)
            left = left[1:]
            continue
        members, mask, blocked, rest = [first], masks[first], 0, []
        for at, j in enumerate(left[1:], start=1):
            m = masks[j]
            if pauli[j] and not m & blocked and bin(mask | m).count("1") <= width:
                members.append(j)
                mask |= m
            else:
                blocked |= m
                rest.append(j)
                if blocked == full or (not mask & ~blocked
                                       and bin(mask).count("1") == width):
                    rest.extend(left[at + 1:])  # nothing further can join
                    break
        if len(members) >= FUSE_MIN_GATES:
            out.append(members)
            left = rest
        else:  # too few to pay for a tile's load and store: the first one alone
            out.append(first)
            left = left[1:]
    return out


def _fuse(ops: list) -> list:
    """Consecutive fixed one-qubit gates on one qubit multiplied into one (in circuit order)."""
    from qdensity.execution.statevector._program import Fixed

    out: list = []
    for op in ops:
        if (isinstance(op, Fixed) and op.matrix is not None and len(op.qubits) == 1 and out
                and isinstance(out[-1], Fixed) and out[-1].matrix is not None
                and out[-1].qubits == op.qubits):
            out[-1] = Fixed(op.qubits, op.matrix @ out[-1].matrix)
        else:
            out.append(op)
    return out


def tables(prog) -> Tables | None:
    """The program's kernel tables (made once, kept on the program), or None when the kernels
    cannot run it (numba missing or disabled, or a fixed gate wider than MAX_DENSE)."""
    if not _numba.available():
        return None
    tab = prog.__dict__.get("_tables")
    if tab is None:
        tab = Tables(prog)
        passes = int(np.count_nonzero(tab.head < 0))
        if np.any(tab.kind == 4) and passes > FUSE_GAIN * len(prog.ops):
            tab = Tables(prog, fuse=False)  # few blocks (all-to-all couplings): gate by gate
        prog.__dict__["_tables"] = tab
    return tab if tab.ok else None


if _numba.available():
    from qdensity.execution.statevector import _kernels_fused as _planar


#: Rows run in threads only above this much work (amplitudes x operations, about 10-20 ms on
#: one core): below it, waking the threads costs more than it saves.
PARALLEL_WORK = 2**24
#: ... and only while the machine has an idle core (:func:`qdensity.cluster.idle_core`).
LOAD_AWARE = True


def row_blocks(rows: int, n: int, ops: int) -> list[tuple[int, int]]:
    """Contiguous blocks ``[lo, hi)`` of the parameter rows, one per thread (one block: no
    threads). Threads: :func:`qdensity.execution._threads.num_threads` (``QDENSITY_NUM_THREADS``
    or the usable cores), at most one per row, only above ``PARALLEL_WORK`` and, where
    ``LOAD_AWARE``, while a core is idle."""
    k = min(num_threads(), rows)
    if k < 2 or rows * ops * 2**n < PARALLEL_WORK or (LOAD_AWARE and not idle_core()):
        return [(0, rows)]
    return split(rows, k)


def forward(states, n, cos, sin, tab: Tables) -> None:
    """``states[r] = U(row r)|0>`` in place: ``states`` (R, 2**n) complex, or planar float
    (2, R, 2**n) (real parts, imaginary parts: no conversion), ``cos``/``sin`` (R, G) of
    ``c * angle`` per rotation; blocks of rows in threads for large work (the same numbers)."""
    planar = states.dtype == np.float64
    R = states.shape[-2]
    re, im = (states[0], states[1]) if planar else (np.empty(states.shape),
                                                    np.empty(states.shape))
    args = tab.args()
    run_blocks(lambda lo, hi: _planar.forward_rows(re[lo:hi], im[lo:hi], n, cos[lo:hi],
                                                   sin[lo:hi], *args),
               row_blocks(R, n, tab.kind.size))
    if not planar:
        states.real = re
        states.imag = im


def backward(phi, lam, n, cos, sin, need, stop, dtheta, tab: Tables) -> None:
    """The backward sweep from the last operation down to operation ``stop``: ``phi``
    (R, 2**n) the forward states and ``lam`` (R, M, 2**n) the observables applied to them
    (both overwritten; or planar float (2, R, 2**n) and (2, R, M, 2**n), used in place);
    fills ``dtheta`` (R, M, G), ``d f_m / d angle_g`` for ``need[g]``; blocks of rows in
    threads for large work (the same numbers)."""
    R = phi.shape[-2]
    if phi.dtype == np.float64:
        pr, pi, lr, li = phi[0], phi[1], lam[0], lam[1]
    else:
        pr, pi = np.ascontiguousarray(phi.real), np.ascontiguousarray(phi.imag)
        lr, li = np.ascontiguousarray(lam.real), np.ascontiguousarray(lam.imag)
    args = tab.args()
    run_blocks(lambda lo, hi: _planar.backward_rows(
        pr[lo:hi], pi[lo:hi], lr[lo:hi], li[lo:hi], n, cos[lo:hi], sin[lo:hi], need, stop,
        dtheta[lo:hi], *args), row_blocks(R, n, tab.kind.size))
