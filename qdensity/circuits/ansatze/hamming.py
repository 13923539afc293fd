"""Hamming-weight-preserving (orthogonal) ansätze of RBS gates (paper Fig. 9, Methods).

Each builder returns a plain ``QuantumCircuit`` whose parameters are one ``ParameterVector``;
``circuit.parameters`` order is gate order. Structure (moments, depth) is read off the circuit
by :func:`qdensity.moments`, never stored beside it.

=============  =============================  ==========================  ====================
builder        RBS gates                      RBS depth (moments)         qubits
=============  =============================  ==========================  ====================
pyramid        n (n - 1) / 2                  2 n - 3                     n >= 2
x_circuit      2 n - 3 (even), 2 n - 2 (odd)  n - 1 (even), n + 1 (odd)   n >= 2
butterfly      (n / 2) log2 n                 log2 n                      n a power of two
round_robin    n (n - 1) / 2                  n - 1 (even n), n (odd n)   n >= 2
=============  =============================  ==========================  ====================

The paper's Fig. 9 caption quotes depth ``2n - 1`` for the pyramid; that counts the two
loader layers around it. The pyramid alone has ``2n - 3`` moments.
"""

from __future__ import annotations

from collections.abc import Iterable

from qiskit.circuit import CircuitInstruction, ParameterVector, QuantumCircuit

from qdensity.analysis.gate_registry import GATES, GIVENS_GATES, RBS
from qdensity.circuits._copying import append_owned, fresh_gate, gc_paused
from qdensity.circuits.gates import FBSGate, RBSGate
from qdensity.validation import (
    MAX_LAYERS,
    Instance,
    Options,
    Qubits,
    SequenceOf,
    Unchecked,
    validates,
)

__all__ = ["pyramid", "x_circuit", "butterfly", "round_robin", "pairs_circuit"]


@validates(
    num_qubits=Qubits(2),
    layers=SequenceOf(Unchecked('pairs checked against num_qubits in the body'), min_len=0,
                      max_len=MAX_LAYERS),
    gate=Options(GIVENS_GATES), parameter_prefix=Instance(str), name=Instance(str),
    insert_barriers=Instance(bool),
)
def pairs_circuit(
    num_qubits: int,
    layers: Iterable[Iterable[tuple[int, int]]],
    *,
    gate: str = RBS.name,
    parameter_prefix: str = "θ",
    name: str = "hw_circuit",
    insert_barriers: bool = False,
) -> QuantumCircuit:
    """Circuit of one parameterised two-mode gate per pair, layer by layer.

    Parameters
    ----------
    num_qubits : int
        Register width.
    layers : iterable of iterable of (int, int)
        Pairs ``(i, j)``, ``i != j``; each becomes a gate on qubits ``(min, max)``.
    gate : {"rbs", "fbs"}
        ``"fbs"`` appends :class:`FBSGate` on the contiguous block ``min .. max`` (a compound
        circuit, Supp. E.2); identical to RBS for adjacent pairs.
    parameter_prefix : str
        Name of the ``ParameterVector``.
    name : str
        Circuit name.
    insert_barriers : bool
        Put a barrier between layers (for drawing; moments are unaffected).

    Returns
    -------
    QuantumCircuit
        ``num_qubits`` qubits, one parameter per pair, in the given order.

    Examples
    --------
    >>> qc = pairs_circuit(3, [[(0, 1)], [(1, 2)]])
    >>> qc.num_parameters, [[qc.find_bit(q).index for q in inst.qubits] for inst in qc.data]
    (2, [[0, 1], [1, 2]])
    """
    ordered = [[(min(p), max(p)) for p in layer] for layer in layers]
    count = sum(len(layer) for layer in ordered)
    theta = ParameterVector(parameter_prefix, count)
    qc = QuantumCircuit(num_qubits, name=name)
    # copied per pair (fresh_gate): a new gate without the checked constructor
    template = RBSGate(theta[0]) if count else None
    with gc_paused():  # one new gate per pair: no garbage cycles
        _append_layers(qc, ordered, num_qubits, gate, template, theta, insert_barriers)
    return qc


def _append_layers(qc: QuantumCircuit, ordered: list, num_qubits: int, gate: str, template,
                   theta, insert_barriers: bool) -> None:
    """The body of :func:`pairs_circuit`: its gates appended to ``qc``."""
    bits = qc.qubits
    k = 0
    for li, layer in enumerate(ordered):
        for i, j in layer:
            if i == j or not (0 <= i < num_qubits and 0 <= j < num_qubits):
                raise ValueError(f"invalid pair {(i, j)} for {num_qubits} qubits")
            if GATES[gate] is RBS or j == i + 1:  # a new gate on checked qubits: appended as is
                append_owned(qc, [CircuitInstruction(fresh_gate(template, [theta[k]]),
                                                     (bits[i], bits[j]))], new=True)
            else:
                qc.append(FBSGate(theta[k], j - i + 1), list(range(i, j + 1)))
            k += 1
        if insert_barriers and li < len(ordered) - 1:
            qc.barrier()


@validates(num_qubits=Qubits(2))
def pyramid(num_qubits: int, **kwargs) -> QuantumCircuit:
    """Pyramid ansatz (Landman et al.; paper Fig. 9a): nearest-neighbour RBS gates.

    Layer ``t = 0 .. 2n - 4`` holds the pairs ``(i, i + 1)`` with ``i = t (mod 2)``,
    ``i <= t`` and ``i <= 2 (n - 2) - t``. It parameterises all of ``SO(n)`` on unary states.

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.
    **kwargs
        ``parameter_prefix``, ``insert_barriers``, ``gate`` as in :func:`pairs_circuit`.

    Returns
    -------
    QuantumCircuit
        ``n (n - 1) / 2`` RBS gates, RBS depth ``2 n - 3``.

    Examples
    --------
    >>> qc = pyramid(4)
    >>> qc.num_parameters, qc.depth()
    (6, 5)
    """
    n = int(num_qubits)
    layers = [
        [(i, i + 1) for i in range(n - 1) if (i - t) % 2 == 0 and i <= t and i <= 2 * (n - 2) - t]
        for t in range(2 * n - 3)
    ]
    return pairs_circuit(n, layers, name=f"pyramid_{n}", **kwargs)


@validates(num_qubits=Qubits(2))
def x_circuit(num_qubits: int, **kwargs) -> QuantumCircuit:
    """X ansatz (Cherrat et al.; paper Fig. 9b): two nearest-neighbour diagonals that cross.

    Step ``t = 0 .. n - 2`` adds ``(t, t + 1)`` and its mirror ``(n - 2 - t, n - 1 - t)``
    (once when they coincide).

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.
    **kwargs
        As in :func:`pairs_circuit`.

    Returns
    -------
    QuantumCircuit
        ``2 n - 3`` RBS gates and depth ``n - 1`` for even ``n``; ``2 n - 2`` gates and depth
        ``n + 1`` for odd ``n`` (the diagonals meet on a shared qubit for two steps).

    Examples
    --------
    >>> qc = x_circuit(4)
    >>> qc.num_qubits, qc.num_parameters, dict(qc.count_ops())
    (4, 5, {'rbs': 5})
    """
    n = int(num_qubits)
    layers = []
    for t in range(n - 1):
        a, b = (t, t + 1), (n - 2 - t, n - 1 - t)
        layers.append([a] if a == b else [a, b])
    return pairs_circuit(n, layers, name=f"x_{n}", **kwargs)


@validates(num_qubits=Qubits(2))
def butterfly(num_qubits: int, **kwargs) -> QuantumCircuit:
    """Butterfly ansatz (Cherrat et al.; paper Fig. 9c), FFT-like connectivity.

    Layer ``l = 0 .. log2(n) - 1`` pairs qubit ``i`` with ``i + n / 2^(l+1)`` for every ``i``
    whose bit ``log2(n) - 1 - l`` is zero.

    Parameters
    ----------
    num_qubits : int
        A power of two, ``>= 2``.
    **kwargs
        As in :func:`pairs_circuit` (``gate="fbs"`` gives the compound butterfly).

    Returns
    -------
    QuantumCircuit
        ``(n / 2) log2 n`` gates, depth ``log2 n``.

    Raises
    ------
    ValueError
        If ``n`` is not a power of two.

    Examples
    --------
    ``(n / 2) log2(n)`` gates in ``log2(n)`` layers:

    >>> qc = butterfly(8)
    >>> qc.num_parameters, qc.depth()
    (12, 3)
    """
    n = int(num_qubits)
    if n & (n - 1):
        raise ValueError(f"butterfly needs num_qubits a power of two (2, 4, 8, ...), got {n}")
    layers = []
    stride = n // 2
    while stride >= 1:
        layers.append([(i, i + stride) for i in range(n) if not i & stride])
        stride //= 2
    return pairs_circuit(n, layers, name=f"butterfly_{n}", **kwargs)


@validates(num_qubits=Qubits(2))
def round_robin_pairs(num_qubits: int) -> list[list[tuple[int, int]]]:
    """Rounds of the circle method: every pair of ``n`` players meets exactly once.

    Parameters
    ----------
    num_qubits : int

    Returns
    -------
    list of list of (int, int)
        ``n - 1`` rounds of ``n / 2`` disjoint pairs (even ``n``); ``n`` rounds of
        ``(n - 1) / 2`` pairs (odd ``n``, one qubit rests each round).

    Examples
    --------
    >>> round_robin_pairs(4)
    [[(0, 3), (1, 2)], [(0, 2), (1, 3)], [(0, 1), (2, 3)]]
    """
    n = int(num_qubits)
    players = list(range(n)) + ([None] if n % 2 else [])
    m = len(players)
    rounds = []
    for _ in range(m - 1):
        pairs = []
        for k in range(m // 2):
            a, b = players[k], players[m - 1 - k]
            if a is not None and b is not None:
                pairs.append((min(a, b), max(a, b)))
        rounds.append(sorted(pairs))
        players = [players[0], players[-1], *players[1:-1]]
    return rounds


@validates(num_qubits=Qubits(2))
def round_robin(num_qubits: int, **kwargs) -> QuantumCircuit:
    """Round-robin ansatz (Hamze et al.; paper Fig. 9d, Fig. 6).

    Layers of disjoint RBS gates from the circle method; across the layers every pair of
    qubits meets exactly once.

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.
    **kwargs
        As in :func:`pairs_circuit`.

    Returns
    -------
    QuantumCircuit
        ``n (n - 1) / 2`` gates in ``n - 1`` layers (even ``n``) or ``n`` layers (odd ``n``).

    Examples
    --------
    Every pair of qubits meets once: ``n (n - 1) / 2`` gates in ``n - 1`` layers (``n`` even):

    >>> qc = round_robin(4)
    >>> qc.num_parameters, qc.depth()
    (6, 3)
    """
    n = int(num_qubits)
    return pairs_circuit(n, round_robin_pairs(n), name=f"round_robin_{n}", **kwargs)
