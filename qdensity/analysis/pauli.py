"""Pauli and Clifford utilities in the binary symplectic picture (paper Methods, Supp. F.2-F.3).

Commuting-generator gradients (Methods, "Commuting-block quantum neural networks") measure a set
of mutually commuting gradient observables from one circuit by appending a *diagonalising
circuit*. This module builds such circuits:

* :func:`diagonalising_clifford` -- a Clifford circuit (``h``, ``s``, ``cx``, ``cz``) that maps
  every operator of a commuting set of Pauli strings to a diagonal ``Z``/``I`` string, by symplectic
  Gaussian elimination;
* :func:`~qdensity.gradients.diagonalising.rbs_diagonalising_layer` (in ``gradients``, as it
  builds RBS gates) -- a layer of ``RBS(pi/4)`` gates (Supp. F.3), which maps
  ``X_i X_j + Y_i Y_j`` to ``Z_j - Z_i`` on each pair.

A Pauli operator on ``n`` qubits is a pair of bit vectors ``(x, z)`` (qubit ``q`` carries
``X^x_q Z^z_q`` up to phase). Two Pauli operators commute iff ``x . z' + z . x' = 0 (mod 2)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import Operator, Pauli, PauliList, SparsePauliOp

from qdensity.analysis._gf2 import all_commute, anticommutation, independent_rows
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    MAX_DENSE_QUBITS,
    Array,
    Instance,
    Interval,
    Qubits,
    SequenceOf,
    check_width,
    validates,
)

__all__ = [
    "MAX_DENSE_QUBITS",
    "ZStringTable",
    "anticommutation",
    "as_pauli_list",
    "commutation_matrix",
    "paulis_commute_pairwise",
    "first_noncommuting_pair",
    "diagonalising_clifford",
    "z_string_values",
    "conjugate_two_qubit",
]


#: What the functions below accept as a set of Pauli strings (declared once).
_PAULIS = Instance((PauliList, SparsePauliOp, Pauli, list, tuple),
                   "PauliList, SparsePauliOp, Pauli or a list of Pauli labels")


@validates(paulis=_PAULIS, name=Instance(str))
def as_pauli_list(paulis, name: str = "paulis") -> PauliList:
    """A ``PauliList`` from a ``PauliList``, a sequence of ``Pauli``/labels, or a ``Pauli``.

    Parameters
    ----------
    paulis : PauliList, Pauli, str or sequence of Pauli / str
    name : str
        Argument name for the error message.

    Returns
    -------
    PauliList

    Examples
    --------
    >>> as_pauli_list(["XX", "ZZ"])
    PauliList(['XX', 'ZZ'])
    """
    if isinstance(paulis, PauliList):
        return paulis
    if isinstance(paulis, (Pauli, str)):
        return PauliList([paulis])
    if isinstance(paulis, SparsePauliOp):
        raise TypeError(f"{name} must be Pauli strings, not a SparsePauliOp; pass op.paulis")
    items = list(paulis)
    if not items:
        raise ValueError(f"{name} must contain at least one Pauli operator, got an empty list")
    try:
        return PauliList(items)
    except Exception as exc:  # qiskit raises QiskitError for bad labels / mixed widths
        raise ValueError(f"{name} could not be read as Pauli operators: {exc}") from exc


# MAX_DENSE_QUBITS (qdensity.validation, shared by every dense path) is the widest register for
# which a dense ``2**n`` table of outcome values is built; wider registers are evaluated on
# observed outcomes only (:class:`ZStringTable`).


class ZStringTable:
    """Linear combinations of diagonal Pauli strings, evaluated on outcomes (Supp. F.3).

    Column ``p`` is ``D_p = sum_r coefficients[r, p] Z^{z_r}``: its value on a measured
    bitstring ``b`` is ``sum_r coefficients[r, p] (-1)^{b . z_r}``. Values are computed from
    the parities of observed bits (memory ``O(outcomes x strings)``, any width); the dense
    ``(2**n, P)`` table is built only up to :data:`MAX_DENSE_QUBITS`.

    Parameters
    ----------
    z : numpy.ndarray of bool, shape (m, n)
        The ``Z`` bits of each string (qubit ``q`` = bit ``q`` of the outcome).
    coefficients : numpy.ndarray of float, shape (m, P)

    Examples
    --------
    >>> t = ZStringTable(np.array([[True, False]]), np.array([[2.0]]))
    >>> t.on_bits(np.array([[0, 0], [1, 0]], dtype=bool)).tolist()
    [[2.0], [-2.0]]
    """

    def __init__(self, z: np.ndarray, coefficients: np.ndarray):
        self.z = np.asarray(z, dtype=bool)
        self.coefficients = np.asarray(coefficients, dtype=float)
        if self.z.ndim != 2 or self.coefficients.shape[:1] != self.z.shape[:1]:
            raise ValueError(
                f"z (m, n) and coefficients (m, P) must agree, got {self.z.shape} and "
                f"{self.coefficients.shape}"
            )

    @property
    def num_qubits(self) -> int:
        """Width ``n`` of the outcomes."""
        return self.z.shape[1]

    def value_range(self) -> np.ndarray:
        """Bound on ``max - min`` of each column over all outcomes, ``2 sum_t |c_t|`` over the
        non-constant strings, shape (P,): the ``R`` of a never-zero (Wilson-form) error bar."""
        varying = self.z.any(axis=1)
        return 2.0 * np.abs(self.coefficients[varying]).sum(axis=0)

    @property
    def num_columns(self) -> int:
        """``P``, the number of observables."""
        return self.coefficients.shape[1]

    def on_bits(self, bits: np.ndarray) -> np.ndarray:
        """Values on outcomes given as bits: ``(..., n)`` bool -> ``(..., P)``."""
        bits = np.asarray(bits)
        if bits.shape[-1] != self.num_qubits:
            raise ValueError(f"bits must have {self.num_qubits} columns, got {bits.shape}")
        if not self.z.shape[0]:
            return np.zeros(bits.shape[:-1] + (self.num_columns,))
        parity = np.rint(bits.astype(np.float64) @ self.z.T.astype(np.float64))
        signs = 1.0 - 2.0 * (parity.astype(np.int64) & 1)
        return signs @ self.coefficients

    def dense(self) -> np.ndarray:
        """The ``(2**n, P)`` table over every outcome (index ``sum_q b_q 2^q``).

        Raises
        ------
        ValueError
            Above :data:`MAX_DENSE_QUBITS` qubits: evaluate on observed outcomes instead.
        """
        n = self.num_qubits
        if n > MAX_DENSE_QUBITS:
            raise ValueError(
                f"a dense table of outcome values needs 2**{n} rows; above "
                f"MAX_DENSE_QUBITS = {MAX_DENSE_QUBITS} qubits estimate from sampled bits "
                "(SamplerEngine) or use the unary engine"
            )
        idx = np.arange(2**n, dtype=np.int64)
        bits = ((idx[:, None] >> np.arange(n)[None, :]) & 1).astype(bool)
        return self.on_bits(bits)

    def with_ancilla_z(self, factor: float = 1.0) -> ZStringTable:
        """The table times ``factor * Z`` on one extra (last) qubit."""
        z = np.concatenate([self.z, np.ones((self.z.shape[0], 1), bool)], axis=1)
        return ZStringTable(z, factor * self.coefficients)

    @classmethod
    def from_operators(cls, ops, num_qubits: int, atol: float = 1e-12) -> ZStringTable:
        """From diagonal ``SparsePauliOp``s (``Z``/``I`` strings, real coefficients), one per
        column."""
        rows: dict[bytes, int] = {}
        zs: list[np.ndarray] = []
        entries: list[tuple[int, int, float]] = []
        for col, op in enumerate(ops):
            pl, coeffs = op.paulis, op.coeffs * (-1j) ** op.paulis.phase
            if pl.x.any():
                bad = int(np.flatnonzero(pl.x.any(axis=1))[0])
                raise ValueError(f"operator {col} is not diagonal: {pl[bad]}")
            for zrow, c in zip(pl.z, coeffs, strict=True):
                if abs(c) <= atol:
                    continue
                if abs(c.imag) > 1e-9:
                    raise RuntimeError(f"diagonal observable has a complex coefficient: {op}")
                key = np.packbits(zrow).tobytes()
                r = rows.setdefault(key, len(rows))
                if r == len(zs):
                    zs.append(np.asarray(zrow, bool))
                entries.append((r, col, c.real))
        coef = np.zeros((len(zs), len(ops)))
        for r, col, c in entries:
            coef[r, col] += c
        z = np.array(zs, dtype=bool).reshape(len(zs), num_qubits)
        return cls(z, coef)


@validates(paulis=_PAULIS)
def commutation_matrix(paulis) -> np.ndarray:
    """Symplectic inner products of every pair of Pauli operators.

    Parameters
    ----------
    paulis : PauliList or sequence of Pauli / str, length m

    Returns
    -------
    numpy.ndarray, shape (m, m), dtype bool
        Entry ``[s, t]`` is True iff ``P_s`` and ``P_t`` anticommute.

    Examples
    --------
    >>> commutation_matrix(["XI", "ZI", "IZ"]).astype(int).tolist()
    [[0, 1, 0], [1, 0, 0], [0, 0, 0]]
    """
    pl = as_pauli_list(paulis)
    return anticommutation(pl.x, pl.z)


@validates(paulis=_PAULIS)
def first_noncommuting_pair(paulis) -> tuple[int, int] | None:
    """Indices ``(s, t)``, ``s < t``, of the first anticommuting pair, or None if all commute.

    Parameters
    ----------
    paulis : PauliList or sequence of Pauli / str

    Returns
    -------
    (int, int) or None
        Lexicographically first pair (row-major over ``s < t``).

    Examples
    --------
    >>> first_noncommuting_pair(["ZZ", "XX", "XI"]), first_noncommuting_pair(["XX", "YY", "ZZ"])
    ((0, 2), None)
    """
    pl = as_pauli_list(paulis)
    if all_commute(pl.x, pl.z):
        return None
    hits = np.argwhere(np.triu(anticommutation(pl.x, pl.z), k=1))
    if hits.size == 0:
        return None
    s, t = hits[0]
    return int(s), int(t)


@validates(paulis=_PAULIS)
def paulis_commute_pairwise(paulis) -> bool:
    """Whether every pair of the given Pauli operators commutes.

    Parameters
    ----------
    paulis : PauliList or sequence of Pauli / str

    Returns
    -------
    bool

    Examples
    --------
    >>> paulis_commute_pairwise(["XX", "YY", "ZZ"])
    True
    >>> paulis_commute_pairwise(["XI", "ZI"])
    False
    """
    return first_noncommuting_pair(paulis) is None


def _apply(pl: PauliList, gate: str, qubits: Sequence[int], circ: QuantumCircuit) -> PauliList:
    """Append ``gate`` to ``circ`` and conjugate the Pauli list by it (Schrödinger frame)."""
    getattr(circ, gate)(*qubits)
    step = QuantumCircuit(circ.num_qubits)
    getattr(step, gate)(*qubits)
    return pl.evolve(step, frame="s")


@validates(paulis=_PAULIS)
def diagonalising_clifford(paulis) -> tuple[QuantumCircuit, PauliList]:
    """Clifford circuit ``C`` that maps each of a commuting set of Paulis to a ``Z``/``I`` string.

    Symplectic Gaussian elimination (paper Methods, "Commuting-block quantum neural networks";
    Bowles et al. 2023, Thm. 1: commuting gradient observables are measured from one circuit
    after a diagonalising unitary). An independent generating set of the commuting group is
    taken one generator at a time; each is first stripped of ``Z`` factors on the pivot qubits
    of earlier generators (multiplying by them), then reduced with ``s``, ``cx``, ``cz`` and
    ``h`` acting only on non-pivot qubits to a single ``Z`` on a fresh pivot qubit. Earlier
    generators, already single ``Z``'s on their pivots, are untouched. Every operator of the
    set is (up to phase) a product of generators, so it ends up a product of ``Z``'s.

    Parameters
    ----------
    paulis : PauliList or sequence of Pauli / str, length m
        Mutually commuting Pauli operators on ``n`` qubits (any phase).

    Returns
    -------
    circuit : QuantumCircuit
        ``n`` qubits, gates ``h``, ``s``, ``cx``, ``cz`` only, at most ``O(n^2)`` of them.
    z_paulis : PauliList, length m
        ``z_paulis[t] = C P_t C^dagger``: no ``X`` part, the phase of ``P_t`` carried along
        (``+-1`` for Hermitian input).

    Raises
    ------
    ValueError
        If two operators anticommute (names the first such pair).

    Examples
    --------
    >>> circ, z = diagonalising_clifford(["XX", "YY"])
    >>> bool(z.x.any())
    False
    """
    pl = as_pauli_list(paulis)
    n = pl.num_qubits
    pair = first_noncommuting_pair(pl)
    if pair is not None:
        s, t = pair
        raise ValueError(
            f"paulis must commute pairwise; paulis[{s}] = {pl[s].to_label()} and "
            f"paulis[{t}] = {pl[t].to_label()} anticommute"
        )
    circ = QuantumCircuit(n, name="diagonalise")
    gens = independent_rows(pl)
    pivots: list[int] = []
    for r in range(len(gens)):
        # Strip Z factors on earlier pivots (the generator has no X there: it commutes with Z_q).
        for s, q in enumerate(pivots):
            if gens.z[r, q]:
                gens[r] = gens[r].compose(gens[s])
        g_x = gens.x[r].copy()
        g_z = gens.z[r].copy()
        free = [q for q in range(n) if q not in pivots]
        if g_x[free].any():
            for q in free:
                if g_x[q] and g_z[q]:  # Y -> X (S Y S^dag = -X)
                    gens = _apply(gens, "s", [q], circ)
            g_x, g_z = gens.x[r].copy(), gens.z[r].copy()
            piv = next(q for q in free if g_x[q])
            for q in free:
                if q == piv:
                    continue
                if g_x[q]:
                    gens = _apply(gens, "cx", [piv, q], circ)
                elif g_z[q]:
                    gens = _apply(gens, "cz", [piv, q], circ)
            gens = _apply(gens, "h", [piv], circ)
        else:
            piv = next(q for q in free if g_z[q])
            for q in free:
                if q != piv and g_z[q]:
                    gens = _apply(gens, "cx", [q, piv], circ)
        pivots.append(piv)
    z_paulis = pl.evolve(circ, frame="s") if circ.size() else pl.copy()
    if z_paulis.x.any():  # a guard on the algebra above, never expected to fire
        raise RuntimeError("diagonalisation left an X component; please report this input")
    return circ, z_paulis


@validates(z_paulis=_PAULIS, num_qubits=[Qubits(1), None])
def z_string_values(z_paulis, num_qubits: int | None = None) -> np.ndarray:
    """Eigenvalue of each diagonal Pauli string on each computational basis state.

    Parameters
    ----------
    z_paulis : PauliList or sequence of Pauli / str, length m
        Diagonal strings (``Z``/``I`` only), any phase.
    num_qubits : int, optional
        Checked against the width of ``z_paulis`` when given.

    Returns
    -------
    numpy.ndarray, shape (2**n, m), complex if any phase is ``+-i`` else float
        Entry ``[b, t]`` is ``<b| P_t |b>`` for the basis state whose integer is ``b``
        (qubit ``q`` is bit ``q``).

    Raises
    ------
    ValueError
        If a string has an ``X`` or ``Y`` factor.

    Examples
    --------
    Rows: the basis states ``b = 0..3``; columns: the strings:

    >>> z_string_values(["ZI", "ZZ"]).tolist()
    [[1.0, 1.0], [1.0, -1.0], [-1.0, -1.0], [-1.0, 1.0]]
    """
    pl = as_pauli_list(z_paulis, "z_paulis")
    n = pl.num_qubits
    if num_qubits is not None and num_qubits != n:
        raise ValueError(f"z_paulis act on {n} qubits, expected num_qubits = {num_qubits}")
    if pl.x.any():
        bad = int(np.flatnonzero(pl.x.any(axis=1))[0])
        raise ValueError(f"z_paulis must be diagonal (Z/I only), got {pl[bad].to_label()}")
    check_width(n, engine="z_string_values (a dense 2**n table)",
                alternative="the measured bits' parities (sampling)", rows=max(len(pl), 1))
    idx = np.arange(2**n, dtype=np.int64)
    bits = ((idx[:, None] >> np.arange(n)[None, :]) & 1).astype(np.int64)  # (2**n, n)
    parity = (bits @ pl.z.T.astype(np.int64)) % 2  # (2**n, m)
    vals = 1.0 - 2.0 * parity
    phase = (-1j) ** pl.phase  # qiskit stores P = (-i)^phase * X^x Z^z
    if np.all(np.isin(pl.phase, (0, 2))):
        return vals * phase.real[None, :]
    return vals * phase[None, :]


_PAULI_1Q = {
    "I": np.eye(2, dtype=complex),
    "X": np.array([[0, 1], [1, 0]], dtype=complex),
    "Y": np.array([[0, -1j], [1j, 0]], dtype=complex),
    "Z": np.array([[1, 0], [0, -1]], dtype=complex),
}
_LABELS_2Q = [a + b for a in "IXYZ" for b in "IXYZ"]  # label "ab": a on the first qubit
_X_OF, _Z_OF = np.array([0, 1, 1, 0], bool), np.array([0, 0, 1, 1], bool)  # I, X, Y, Z


_TRANSFER_CACHE: dict[bytes, np.ndarray] = {}


def _transfer_matrix(unitary: np.ndarray) -> np.ndarray:
    """``T[a, b] = Tr(s_a U s_b U^dag) / 4`` over two-qubit Paulis ``s`` (first qubit = low bit)."""
    mats = [np.kron(_PAULI_1Q[lab[1]], _PAULI_1Q[lab[0]]) for lab in _LABELS_2Q]
    out = np.empty((16, 16), dtype=complex)
    for b, mb in enumerate(mats):
        conj = unitary @ mb @ unitary.conj().T
        for a, ma in enumerate(mats):
            out[a, b] = np.trace(ma.conj().T @ conj) / 4
    return out


@validates(
    op=Instance(SparsePauliOp), unitary=Array(shape=(4, 4), dtype='complex'),
    qubits=SequenceOf(Interval(int, 0, MAX_CIRCUIT_QUBITS), min_len=2, max_len=2),
    atol=Interval(float, 0),
)
def conjugate_two_qubit(
    op: SparsePauliOp, unitary, qubits: tuple[int, int], *, atol: float = 1e-12
) -> SparsePauliOp:
    """``U op U^dagger`` for a two-qubit unitary ``U`` on ``qubits``, in the Pauli basis.

    Works term by term (a 16 x 16 transfer matrix on the pair), so it costs ``O(terms)`` rather
    than a dense ``2^n`` matrix.

    Parameters
    ----------
    op : SparsePauliOp
        On ``n`` qubits.
    unitary : array_like, shape (4, 4) or Gate
        In Qiskit's convention (basis index ``q_0 + 2 q_1`` for ``qubits = (q_0, q_1)``).
    qubits : (int, int)
    atol : float
        Coefficients below ``atol`` are dropped by ``simplify``.

    Returns
    -------
    SparsePauliOp

    Examples
    --------
    >>> from qiskit.circuit.library import CXGate
    >>> from qiskit.quantum_info import SparsePauliOp
    >>> conjugate_two_qubit(SparsePauliOp("IX"), CXGate(), (0, 1)).paulis  # X on the control
    PauliList(['XX'])
    """
    mat = Operator(unitary).data
    q0, q1 = (int(q) for q in qubits)
    key = mat.tobytes()
    tm = _TRANSFER_CACHE.get(key)
    if tm is None:
        tm = _TRANSFER_CACHE.setdefault(key, _transfer_matrix(mat))
    # all terms at once: each term's Pauli pair on (q0, q1) indexes a column of the transfer
    # matrix, and each of its non-zero rows is one output term (term by term, rows ascending)
    x, z = op.paulis.x, op.paulis.z
    coeffs = op.coeffs * (-1j) ** op.paulis.phase  # the labels' phases into the coefficients
    code = (x.astype(np.intp) + 3 * z - 2 * (x & z))[:, [q0, q1]]  # I, X, Y, Z -> 0, 1, 2, 3
    b = 4 * code[:, 0] + code[:, 1]
    t, a = np.nonzero(np.abs(tm[:, b]).T > atol)
    if not t.size:
        return SparsePauliOp(["I" * op.num_qubits], [0.0])
    nx, nz = x[t], z[t]
    nx[:, q0], nz[:, q0] = _X_OF[a // 4], _Z_OF[a // 4]
    nx[:, q1], nz[:, q1] = _X_OF[a % 4], _Z_OF[a % 4]
    return SparsePauliOp(PauliList.from_symplectic(nz, nx),
                         coeffs[t] * tm[a, b[t]]).simplify(atol=atol)
