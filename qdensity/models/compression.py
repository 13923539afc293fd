"""Compressed decompositions (paper Fig. 11a iii, Supp. H.1-H.2): runs of RBS gates on one
pair merged into one gate.

``RBS(a) RBS(b) = RBS(a + b)`` on the same pair of qubits (both are ``exp(-i t Q)`` with the
same generator ``Q``), so a run of RBS gates on one pair with nothing else touching those
qubits in between is one gate with one angle. The odd-even split of the pyramid
(:func:`qdensity.models.decompositions.odd_even`) puts up to ``n - 1`` gates in series on each
pair; merging them gives the "compressed" density OrthoQNN of the paper's Fig. 11 (one RBS per
pair: ``floor(n / 2)`` angles in ``U_even``, ``floor((n - 1) / 2)`` in ``U_odd``), which
expresses exactly the same set of maps as the uncompressed model.
"""

from __future__ import annotations

from typing import cast

from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.circuits.gates import RBSGate
from qdensity.models.decompositions import Decomposition, odd_even
from qdensity.validation import check_circuit

__all__ = ["merge_rbs_runs", "compressed_odd_even"]


def merge_rbs_runs(circuit: QuantumCircuit, parameter_prefix: str = "θ"
                   ) -> tuple[QuantumCircuit, list[list[int]]]:
    """Merge every run of consecutive RBS gates on the same (ordered) pair into one RBS.

    Parameters
    ----------
    circuit : QuantumCircuit
        Any circuit; gates other than :class:`~qdensity.circuits.gates.RBSGate` are kept as
        they are and end a run on their qubits.
    parameter_prefix : str
        Name of the new ``ParameterVector`` (one parameter per RBS of the result).

    Returns
    -------
    merged : QuantumCircuit
        Same width; its RBS gates carry fresh parameters ``parameter_prefix[i]`` in gate order.
    groups : list of list of int
        ``groups[i]``: positions in ``circuit.data`` of the RBS gates merged into the result's
        ``i``-th RBS. With angle ``sum of the group's angles`` the result equals the input.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.models.decompositions import odd_even
    >>> even = odd_even(pyramid(4)).sub_unitaries[0]
    >>> merged, groups = merge_rbs_runs(even)
    >>> even.num_parameters, merged.num_parameters, groups
    (4, 2, [[0, 1, 3], [2]])
    """
    check_circuit(circuit)
    ops: list[list] = []  # [instruction, qubit indices, group or None]
    last: dict[int, int] = {}
    for pos, inst in enumerate(circuit.data):
        qubits = tuple(circuit.find_bit(q).index for q in inst.qubits)
        if isinstance(inst.operation, RBSGate):
            before = {last.get(q) for q in qubits}
            if len(before) == 1 and None not in before:
                prev = ops[cast(int, before.pop())]  # None is not in before
                if prev[2] is not None and prev[1] == qubits:
                    prev[2].append(pos)
                    continue
            group = [pos]
        else:
            group = None
        ops.append([inst, qubits, group])
        for q in qubits:
            last[q] = len(ops) - 1
    count = sum(op[2] is not None for op in ops)
    theta = ParameterVector(parameter_prefix, count)
    out = circuit.copy_empty_like(name=f"{circuit.name}_merged")
    groups, i = [], 0
    for inst, qubits, group in ops:
        if group is None:
            out.append(inst)
        else:
            out.append(RBSGate(theta[i]), list(qubits))
            groups.append(group)
            i += 1
    return out, groups


def compressed_odd_even(circuit: QuantumCircuit) -> Decomposition:
    """The odd-even split with each pair's run of RBS gates merged (paper Fig. 11a iii).

    Parameters
    ----------
    circuit : QuantumCircuit
        Typically :func:`qdensity.circuits.ansatze.pyramid` (``n (n - 1) / 2`` RBS gates).

    Returns
    -------
    Decomposition
        ``[U_even, U_odd]`` with independent parameters ``θ0``, ``θ1`` (for the pyramid one RBS
        per pair: ``n - 1`` angles in all); ``notes["groups"]`` holds, per sub-unitary, the
        positions in that odd-even sub-unitary of the gates each new angle replaces.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> compressed_odd_even(pyramid(8)).parameter_counts()
    [4, 3]
    """
    split = odd_even(circuit)
    parts, groups = [], []
    for k, sub in enumerate(split.sub_unitaries):
        merged, g = merge_rbs_runs(sub, parameter_prefix=f"θ{k}")
        merged.name = f"{sub.name}_compressed"
        parts.append(merged)
        groups.append(g)
    return Decomposition(f"{circuit.name}_odd_even_compressed", parts, circuit,
                         independent=True, notes={"groups": groups})
