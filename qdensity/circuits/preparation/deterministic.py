"""The deterministic density QNN of Fig. 1b / Fig. 13a (Supp. I.2).

``Load(sqrt(alpha))`` on the ancilla register ``mix``, ``V(x)`` on ``data``, then each ``U_k``
controlled on ``mix[k]`` (:func:`controlled_subunitary`); the ``data`` marginal is ``rho``
of eq. 1, with no post-selection.
"""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.circuit import QuantumCircuit

from qdensity.circuits.preparation._common import (
    MIX_REGISTER,
    _check_alpha,
    _check_loader,
    _check_sub_unitaries,
    _mix_and_data,
)
from qdensity.circuits.preparation._controlled import _append_controlled_circuit
from qdensity.validation import MAX_SUBUNITARIES, Array, Circuit, SequenceOf, validates

__all__ = ["deterministic_circuit"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    loader=[Circuit(min_qubits=1), None],
)
def deterministic_circuit(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> QuantumCircuit:
    """The deterministic density QNN of Fig. 1b / Fig. 13a (Supp. I.2).

    ``Load(sqrt(alpha))`` puts ``sum_k sqrt(alpha_k) |e_k>`` on ``mix`` (a unary loader,
    RBS depth ``ceil(log2 K)``); ``V(x)`` loads ``|x>`` on ``data``; then ``U_k`` acts on
    ``data`` controlled on ``mix[k]``. The joint state is
    ``sum_k sqrt(alpha_k) |e_k> U_k |x>``, so tracing out ``mix`` leaves exactly
    ``rho = sum_k alpha_k U_k |x><x| U_k^dagger`` (eq. 1) on ``data``, with no post-selection.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each, parameterised or bound.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries (non-negative, sums to 1; not renormalised).
        Zeros are allowed.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits. None: ``|x> = |0...0>``.

    Returns
    -------
    QuantumCircuit
        ``K + n`` qubits: register ``"mix"`` (qubits ``0 .. K-1``) then ``"data"``
        (qubits ``K .. K+n-1``); ``metadata["alpha"]`` holds ``alpha``.

    Raises
    ------
    TypeError
        If ``sub_unitaries`` is not a sequence of circuits or ``loader`` not a circuit.
    ValueError
        For ``K = 0``, sub-unitaries of different widths, ``alpha`` of the wrong length or
        off the simplex, a loader of the wrong width, or clashing parameter names.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid, round_robin
    >>> qc = deterministic_circuit([pyramid(4, parameter_prefix="a"),
    ...                             round_robin(4, parameter_prefix="b")], [0.25, 0.75])
    >>> [r.name for r in qc.qregs], qc.num_parameters
    (['mix', 'data'], 12)
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    arr = _check_alpha(alpha, len(circuits))
    loader = _check_loader(loader, circuits[0].num_qubits)
    qc, mix, data = _mix_and_data(circuits, arr, loader, "density_deterministic")
    for k, circ in enumerate(circuits):
        _append_controlled_circuit(qc, mix[k], list(data), circ)
    qc.metadata = {"alpha": arr.tolist(), "mix_register": MIX_REGISTER}
    return qc
