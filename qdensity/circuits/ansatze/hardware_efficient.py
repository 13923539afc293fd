"""Hardware-efficient ansatz with alternating CNOT ladders (Kandala et al.; paper Fig. 3).

A ``D``-layer hardware-efficient circuit on ``n`` qubits has one single-qubit Pauli rotation
per qubit per layer (``n D`` parameters) followed by nearest-neighbour CNOTs. As in the paper's
Fig. 3 the ladder's direction alternates between layers, so that the sub-unitaries a density QNN
extracts from different layers entangle differently (Sec. "Hardware efficient quantum neural
networks"). The layers are not stored beside the circuit: the rotations of layer ``d`` form
moment ``d`` of ``qdensity.analysis.moments(circuit, include_unparameterised=False)``.
"""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.validation import (
    Instance,
    Layers,
    Options,
    Qubits,
    SequenceOf,
    validates,
)

__all__ = ["hardware_efficient", "ROTATIONS", "ENTANGLEMENTS"]

#: Single-qubit rotation gates a layer may use.
ROTATIONS = ("rx", "ry", "rz")
#: Entangling layouts: an open nearest-neighbour ladder, or the ladder closed into a ring.
ENTANGLEMENTS = ("ladder", "ring")


def _ladder_pairs(n: int, layer: int, entanglement: str) -> list[tuple[int, int]]:
    """(control, target) pairs of layer ``layer``'s CNOT ladder, in circuit order."""
    pairs = [(i, i + 1) for i in range(n - 1)]
    if entanglement == "ring" and n > 2:
        pairs.append((n - 1, 0))
    if layer % 2 == 1:
        pairs = [(t, c) for c, t in reversed(pairs)]
    return pairs


@validates(
    num_qubits=Qubits(2), reps=Layers(),
    rotations=[Options(ROTATIONS), SequenceOf(Options(ROTATIONS), max_len=len(ROTATIONS))],
    entanglement=Options(ENTANGLEMENTS), parameter_prefix=Instance(str),
    insert_barriers=Instance(bool), name=[Instance(str), None],
)
def hardware_efficient(
    num_qubits: int,
    reps: int,
    rotations: str | Sequence[str] = ("ry",),
    entanglement: str = "ladder",
    *,
    parameter_prefix: str = "θ",
    insert_barriers: bool = False,
    name: str | None = None,
) -> QuantumCircuit:
    """Hardware-efficient ansatz of ``reps`` layers with alternating CNOT ladders (Fig. 3).

    Layer ``d = 0 .. D - 1`` applies ``R(θ[d n + q])`` to every qubit ``q``, where ``R`` is the
    gate named ``rotations[d % len(rotations)]``, and then a CNOT ladder:

    * even ``d``: ``cx(0, 1), cx(1, 2), ..., cx(n - 2, n - 1)``;
    * odd ``d``: the same ladder run backwards with control and target swapped,
      ``cx(n - 1, n - 2), ..., cx(1, 0)``.

    With ``entanglement="ring"`` (``n >= 3``) the ladder is closed by ``cx(n - 1, 0)`` on even
    layers (``cx(0, n - 1)``, applied first, on odd layers).

    The circuit implements ``U = L_{D-1} R_{D-1} ... L_0 R_0`` with
    ``R_d = ⊗_q R(θ[d n + q])`` and ``L_d`` the ladder. Parameter count: ``n D``.

    Parameters
    ----------
    num_qubits : int
        ``n >= 2``.
    reps : int
        Number of layers ``D >= 1``.
    rotations : str or sequence of str
        Gate names from ``("rx", "ry", "rz")``, cycled over layers.
    entanglement : {"ladder", "ring"}
        Open nearest-neighbour ladder (paper Fig. 3) or the ladder closed into a ring.
    parameter_prefix : str
        Name of the trainable ``ParameterVector`` (length ``n D``).
    insert_barriers : bool
        Put a barrier after each layer's rotations and after each ladder (for drawing).
    name : str, optional
        Circuit name; defaults to ``"hardware_efficient_{n}x{D}"``.

    Returns
    -------
    QuantumCircuit
        ``n`` qubits, ``n D`` parameters in layer-major order (``θ[d n + q]``), ``D (n - 1)``
        CNOTs for the ladder (``D n`` for the ring).

    Raises
    ------
    ValueError
        For ``num_qubits < 2``, ``reps < 1``, an unknown rotation or entanglement.

    Examples
    --------
    >>> qc = hardware_efficient(4, 3, rotations=("rx", "ry"))
    >>> qc.num_parameters, qc.count_ops()["cx"]
    (12, 9)
    >>> cx = [inst for inst in qc.data if inst.operation.name == "cx"]
    >>> [qc.find_bit(inst.qubits[0]).index for inst in cx[3:6]]  # layer 1 runs backwards
    [3, 2, 1]
    """
    n, depth = int(num_qubits), int(reps)
    rots = (rotations,) if isinstance(rotations, str) else tuple(rotations)
    theta = ParameterVector(parameter_prefix, n * depth)
    qc = QuantumCircuit(n, name=name or f"hardware_efficient_{n}x{depth}")
    for d in range(depth):
        gate = getattr(qc, rots[d % len(rots)])
        for q in range(n):
            gate(theta[d * n + q], q)
        if insert_barriers:
            qc.barrier()
        for control, target in _ladder_pairs(n, d, entanglement):
            qc.cx(control, target)
        if insert_barriers and d < depth - 1:
            qc.barrier()
    return qc
