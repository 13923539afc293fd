"""Translation-equivariant models of Bowles et al. and the bars-and-dots task (paper Fig. 4).

Qubits sit on a ring of ``n`` sites; the symmetry is the cyclic shift ``i -> i + 1 (mod n)``.
A Pauli string made of one Pauli ``P`` on a set ``S`` of sites (identity elsewhere) is named by
``S``; the cyclic shift acts on these sets, and its orbits are the *translation classes*.
The twirl ``sym(P_S)`` (paper Sec. "Equivariant density QNN") is the sum of the distinct strings
of the class of ``S``; it commutes with the shift, so ``exp(-i θ sym(P_S))`` is equivariant.

* :func:`equivariant_commuting` -- the commuting-generator "XX" (``pauli="X"``) and "YY"
  (``pauli="Y"``) models: one shared parameter per class of weight ``1 .. max_weight``.
  All generators commute, so the circuit is exactly ``exp(-i Σ_c θ_c sym_c)``.
* :func:`equivariant_noncommuting` -- the layered model of Bowles et al., Fig. 5c:
  ``exp(-i a Σ Z_i)``, ``exp(-i b Σ Y_i)`` and the ``X_i X_{i+d}`` classes per layer.
* :func:`angle_encoding`, :func:`equivariant_observable` and :func:`bars_and_dots` complete
  the task of Methods "Equivariant density QNN".

Each string becomes one ``PauliEvolutionGate`` of a single-term ``SparsePauliOp`` with time
equal to its class parameter, so ``qdensity.analysis.instruction_generator`` reads the
generator off the circuit and every transpiler turns it into a CNOT ladder.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from qiskit.circuit import CircuitInstruction, ParameterVector, QuantumCircuit
from qiskit.circuit.library import PauliEvolutionGate
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits._copying import fresh_gate
from qdensity.datasets.bars_and_dots import bars_and_dots
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    Instance,
    Interval,
    Layers,
    Options,
    Qubits,
    validates,
)

__all__ = [
    "translation_classes",
    "equivariant_commuting",
    "equivariant_noncommuting",
    "angle_encoding",
    "equivariant_observable",
    "bars_and_dots",
    "PAULIS",
]

#: Paulis a commuting-generator model may use.
PAULIS = ("X", "Y", "Z")


def _canonical(supports: np.ndarray, n: int) -> np.ndarray:
    """Smallest sorted tuple among the cyclic shifts of each row of ``supports``.

    ``supports`` (S, k): sorted supports, one a row. The smallest shift starts at 0, so only
    the ``k`` shifts that move one member to 0 are candidates; moving member ``j`` to 0 maps
    the sorted row ``a`` to the sorted row ``(a_j, .., a_{k-1}, a_0 + n, .., a_{j-1}) - a_j``
    (a rotation). The candidates are compared lexicographically, all rows at once.
    """
    best = supports - supports[:, :1]
    rows = np.arange(len(supports))
    for j in range(1, supports.shape[1]):
        cand = np.concatenate([supports[:, j:], supports[:, :j] + n], axis=1) - supports[:, j:j + 1]
        diff = cand != best
        first = np.argmax(diff, axis=1)  # first differing position (0 when none differs)
        smaller = cand[rows, first] < best[rows, first]
        best[smaller] = cand[smaller]
    return best


@validates(num_qubits=Qubits(1), max_weight=Interval(int, 1, MAX_CIRCUIT_QUBITS))
def translation_classes(num_qubits: int, max_weight: int) -> list[list[tuple[int, ...]]]:
    """Orbits of qubit subsets of size ``1 .. max_weight`` under the cyclic shift of a ring.

    Two supports lie in one class iff one is a cyclic shift of the other. The number of
    classes of weight ``k`` is the number of binary necklaces of length ``n`` with ``k`` ones,
    ``(1/n) Σ_{d | gcd(n, k)} φ(d) C(n/d, k/d)`` (Burnside).

    Parameters
    ----------
    num_qubits : int
        Ring size ``n >= 1``.
    max_weight : int
        Largest support size, ``1 <= max_weight <= n``.

    Returns
    -------
    list of list of tuple of int
        Classes ordered by weight, then by their lexicographically smallest member; each class
        lists its distinct supports (sorted tuples of qubit indices) in lexicographic order.

    Raises
    ------
    ValueError
        If ``max_weight`` is outside ``1 .. num_qubits``.

    Examples
    --------
    >>> [len(translation_classes(10, 3)), len(translation_classes(4, 2))]
    [18, 3]
    >>> translation_classes(4, 2)[2]
    [(0, 2), (1, 3)]
    """
    n, k_max = int(num_qubits), int(max_weight)
    if k_max > n:
        raise ValueError(
            f"max_weight must be <= num_qubits ({n}) (a string has at most one Pauli per "
            f"qubit), got {k_max}"
        )
    classes: list[list[tuple[int, ...]]] = []
    for k in range(1, k_max + 1):
        # every support of weight k in lexicographic order, one a row; its class is named by
        # its canonical form, the class's smallest member (_canonical)
        supports = list(combinations(range(n), k))
        rows = np.array(supports, dtype=np.int64).reshape(len(supports), k)
        canonical = _canonical(rows, n)
        if k * np.log2(n) < 62:  # one integer a form, in the forms' lexicographic order
            canonical = canonical @ (n ** np.arange(k - 1, -1, -1, dtype=np.int64))
            _, owner = np.unique(canonical, return_inverse=True)
        else:
            _, owner = np.unique(canonical, axis=0, return_inverse=True)
        owner = owner.ravel()
        order = np.argsort(owner, kind="stable")  # by class, lexicographic inside
        sizes = np.bincount(owner)
        ends = np.cumsum(sizes)
        starts = ends - sizes
        members = [supports[i] for i in order.tolist()]
        classes.extend(members[a:b] for a, b in zip(starts.tolist(), ends.tolist(), strict=True))
    return classes


def _append_string(qc: QuantumCircuit, pauli: str, support: tuple[int, ...], time) -> None:
    """Append ``exp(-i time P_support)`` as a single-term ``PauliEvolutionGate``."""
    op = SparsePauliOp(pauli * len(support))
    qc.append(PauliEvolutionGate(op, time=time), list(support))


@validates(
    num_qubits=Qubits(2), pauli=Options(PAULIS), max_weight=Interval(int, 1, MAX_CIRCUIT_QUBITS),
    parameter_prefix=Instance(str), name=[Instance(str), None],
)
def equivariant_commuting(
    num_qubits: int,
    pauli: str = "X",
    max_weight: int = 3,
    *,
    parameter_prefix: str = "θ",
    name: str | None = None,
) -> QuantumCircuit:
    """Commuting-generator equivariant model ``U_PP(θ) = exp(-i Σ_c θ_c sym_c(P))`` (Fig. 4a).

    One shared parameter ``θ_c`` per translation class ``c`` of supports of size
    ``1 .. max_weight`` (:func:`translation_classes`), generator ``sym_c = Σ_{S in c} P_S``
    with ``P_S = ⊗_{q in S} P_q``. All strings commute, so the product of one
    ``exp(-i θ_c P_S)`` per string is exact. ``pauli="X"`` is the paper's "XX" model and
    ``pauli="Y"`` the "YY" model (Bowles et al., "Backpropagation scaling in parameterised
    quantum circuits").

    Parameter count: the number of binary necklaces of length ``n`` with ``1 .. max_weight``
    ones; for ``max_weight = 3`` and ``n >= 3`` that is
    ``1 + floor(n / 2) + N_3(n)`` with ``N_3(n) = (C(n, 3) + (2 n / 3) [3 | n]) / n``
    (18 for ``n = 10``: ``1 + 5 + 12``). Gates: ``Σ_{k <= max_weight} C(n, k)`` Pauli
    evolutions.

    Parameters
    ----------
    num_qubits : int
        Ring size ``n >= 2``.
    pauli : {"X", "Y", "Z"}
        The Pauli of every generator string.
    max_weight : int
        Largest Pauli weight, ``1 <= max_weight <= n``.
    parameter_prefix : str
        Name of the trainable ``ParameterVector``, one entry per class in the order of
        :func:`translation_classes`.
    name : str, optional
        Circuit name; defaults to ``"equivariant_{pp}_{n}"``, e.g. ``"equivariant_xx_10"``.

    Returns
    -------
    QuantumCircuit
        ``n`` qubits; ``PauliEvolutionGate`` instructions, class by class.

    Raises
    ------
    ValueError
        For ``num_qubits < 2``, an unknown ``pauli`` or ``max_weight`` outside ``1 .. n``.

    Examples
    --------
    >>> qc = equivariant_commuting(10, "X", max_weight=3)
    >>> qc.num_parameters, len(qc.data)
    (18, 175)
    """
    n = int(num_qubits)
    p = pauli
    classes = translation_classes(n, max_weight)
    theta = ParameterVector(parameter_prefix, len(classes))
    qc = QuantumCircuit(n, name=name or f"equivariant_{p.lower() * 2}_{n}")
    templates: dict[int, PauliEvolutionGate] = {}
    bits = qc.qubits
    for c, cls in enumerate(classes):
        # one gate per weight, copied per string with its class parameter: equal gates at a
        # fraction of the cost of building a SparsePauliOp and a PauliEvolutionGate for each
        # of the C(n, k) strings (or each class). The copy is shallow with its own parameter
        # list and no definition (the operator, immutable, is shared: fresh_gate), appended
        # unchecked: the qubits are distinct and in range by construction.
        k, t = len(cls[0]), theta[c]
        gate = templates.get(k)
        if gate is None:
            gate = templates[k] = PauliEvolutionGate(SparsePauliOp(p * k), time=t)
        for support in cls:
            qc._append(CircuitInstruction(fresh_gate(gate, [t]), tuple([bits[q] for q in support])))
    return qc


def _distance_classes(n: int) -> list[list[tuple[int, ...]]]:
    """Distinct ``X_i X_{i+d}`` supports for ``d = 1 .. floor(n / 2)``."""
    out = []
    for d in range(1, n // 2 + 1):
        supports = sorted({tuple(sorted((i, (i + d) % n))) for i in range(n)})
        out.append(supports)
    return out


@validates(
    num_qubits=Qubits(2), layers=Layers(), parameter_prefix=Instance(str),
    name=[Instance(str), None],
)
def equivariant_noncommuting(
    num_qubits: int,
    layers: int,
    *,
    parameter_prefix: str = "θ",
    name: str | None = None,
) -> QuantumCircuit:
    """Non-commuting translation-equivariant model (Bowles et al., Fig. 5c; paper Fig. 4c).

    Each layer ``l`` applies, in this order,

    1. ``exp(-i a_l Σ_i Z_i)``,
    2. ``exp(-i b_l Σ_i Y_i)``,
    3. ``exp(-i c_{l,d} Σ_i X_i X_{i+d})`` for ``d = 1 .. floor(n / 2)`` (indices mod ``n``;
       the sum runs over the distinct pairs, so ``n / 2`` of them for ``d = n / 2``).

    Inside each factor the strings commute, so each factor is exact; the factors do not
    commute with each other. Parameter count: ``layers (2 + floor(n / 2))``, ordered
    ``a_l, b_l, c_{l,1}, ..., c_{l,floor(n/2)}`` layer by layer.

    Parameters
    ----------
    num_qubits : int
        Ring size ``n >= 2``.
    layers : int
        Number of layers ``>= 1``.
    parameter_prefix : str
        Name of the trainable ``ParameterVector``.
    name : str, optional
        Circuit name; defaults to ``"equivariant_noncommuting_{n}x{layers}"``.

    Returns
    -------
    QuantumCircuit
        ``n`` qubits, ``layers (2 n + Σ_d |class d|)`` Pauli evolutions.

    Examples
    --------
    >>> equivariant_noncommuting(6, 2).num_parameters
    10
    """
    n, num_layers = int(num_qubits), int(layers)
    xx_classes = _distance_classes(n)
    per_layer = 2 + len(xx_classes)
    theta = ParameterVector(parameter_prefix, num_layers * per_layer)
    qc = QuantumCircuit(n, name=name or f"equivariant_noncommuting_{n}x{num_layers}")
    for layer in range(num_layers):
        base = layer * per_layer
        for q in range(n):
            _append_string(qc, "Z", (q,), theta[base])
        for q in range(n):
            _append_string(qc, "Y", (q,), theta[base + 1])
        for d, cls in enumerate(xx_classes):
            for support in cls:
                _append_string(qc, "X", support, theta[base + 2 + d])
    return qc


@validates(num_qubits=Qubits(1), parameter_prefix=Instance(str))
def angle_encoding(num_qubits: int, *, parameter_prefix: str = "x") -> QuantumCircuit:
    """Angle encoding ``|x> = ⊗_i R_y(π x_i / 2)|0>`` (Methods, "Equivariant density QNN").

    Qubit ``i`` ends in ``cos(π x_i / 4)|0> + sin(π x_i / 4)|1>``; a shift of ``x`` shifts the
    qubits, which is what makes the models above equivariant end to end.

    Parameters
    ----------
    num_qubits : int
        ``d >= 1``, one qubit per feature.
    parameter_prefix : str
        Name of the data ``ParameterVector`` (length ``d``).

    Returns
    -------
    QuantumCircuit
        ``d`` ``ry`` gates with angles ``π/2 · x[i]``.

    Examples
    --------
    >>> angle_encoding(3).num_parameters
    3
    """
    n = int(num_qubits)
    x = ParameterVector(parameter_prefix, n)
    qc = QuantumCircuit(n, name=f"angle_encoding_{n}")
    for i in range(n):
        qc.ry(np.pi / 2 * x[i], i)
    return qc


@validates(num_qubits=Qubits(1))
def equivariant_observable(num_qubits: int) -> SparsePauliOp:
    """The translation-invariant observable ``H = Σ_i Z_i`` (Methods; model output ``Tr(H ρ)``).

    Parameters
    ----------
    num_qubits : int
        ``n >= 1``.

    Returns
    -------
    SparsePauliOp
        ``n`` terms ``Z_i`` with coefficient 1 (eigenvalues ``-n .. n``).

    Examples
    --------
    >>> equivariant_observable(3)
    SparsePauliOp(['IIZ', 'IZI', 'ZII'],
                  coeffs=[1.+0.j, 1.+0.j, 1.+0.j])
    """
    n = int(num_qubits)
    return SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)
