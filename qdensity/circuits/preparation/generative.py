"""Generative density QNN for Hamming-weight-preserving sub-unitaries (Fig. 13b, Supp. I.3).

``V = 1``; per ``k`` the sandwich ``U_k^dagger . CNOT(mix[k] -> data[s]) . U_k`` replaces the
controlled sub-unitary, so ``K`` CNOTs are the only controlled gates.
"""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.circuit import QuantumCircuit

from qdensity.analysis.structure import is_hamming_weight_preserving
from qdensity.circuits.preparation._common import (
    MIX_REGISTER,
    _append_circuit,
    _check_alpha,
    _check_sub_unitaries,
    _mix_and_data,
)
from qdensity.validation import (
    MAX_CIRCUIT_QUBITS,
    MAX_SUBUNITARIES,
    Array,
    Circuit,
    Interval,
    SequenceOf,
    validates,
)

__all__ = ["hw_generative_circuit"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    start_qubit=Interval(int, 0, MAX_CIRCUIT_QUBITS),
)
def hw_generative_circuit(
    sub_unitaries: Sequence[QuantumCircuit], alpha, start_qubit: int = 0
) -> QuantumCircuit:
    """Generative density QNN for Hamming-weight-preserving sub-unitaries (Fig. 13b, Supp. I.3).

    No data loader (``V(x) = 1``). ``mix`` holds ``sum_k sqrt(alpha_k)|e_k>``; for each
    ``k``: ``U_k^dagger`` on ``data``, ``CNOT(mix[k] -> data[start_qubit])``, ``U_k`` on
    ``data``. On ``|0...0>`` a HW-preserving ``U_k`` is a phase, so the pair ``U_k^dagger,
    U_k`` cancels unless the CNOT fired; in branch ``k`` the data ends in
    ``U_k |e_s>`` (up to a phase), so the data marginal is
    ``sum_k alpha_k U_k |e_s><e_s| U_k^dagger`` with ``s = start_qubit``. No controlled
    sub-unitaries are needed: ``K`` CNOTs replace them.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        Hamming-weight-preserving ``U_k`` on ``n`` qubits (checked with
        :func:`qdensity.analysis.is_hamming_weight_preserving`).
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    start_qubit : int
        Data qubit ``s`` that the CNOTs excite (unary basis state ``|e_s>``, statevector
        entry ``2**s``).

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits, registers ``"mix"`` then ``"data"``.

    Raises
    ------
    ValueError
        If a sub-unitary is not Hamming-weight preserving or ``start_qubit`` is out of range.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> qc = hw_generative_circuit([pyramid(4, parameter_prefix="a"),
    ...                             pyramid(4, parameter_prefix="b")], [0.5, 0.5])
    >>> qc.count_ops()["cx"]
    2
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    n = circuits[0].num_qubits
    start = int(start_qubit)
    if start >= n:
        raise ValueError(f"start_qubit must be in [0, {n - 1}] (a data qubit), got {start}")
    for k, circ in enumerate(circuits):
        if not is_hamming_weight_preserving(circ):
            raise ValueError(
                f"sub_unitaries[{k}] ({circ.name!r}) is not Hamming-weight preserving; the "
                "circuit of Fig. 13b needs HW-preserving sub-unitaries (RBS, FBS, rz, rzz, ...)"
            )
    qc, mix, data = _mix_and_data(circuits, arr, None, "density_hw_generative")
    for k, circ in enumerate(circuits):
        _append_circuit(qc, circ.inverse(), list(data))
        qc.cx(mix[k], data[start])
        _append_circuit(qc, circ, list(data))
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER, "start_qubit": start}
    return qc
