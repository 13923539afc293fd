"""The randomised density QNN of Fig. 1c: one circuit ``U_k V(x)`` per sub-unitary.

No ancillas and no controlled gates: each shot runs circuit ``k`` with probability
``alpha_k`` (paper eq. 1); the shot schedule is the engine's job.
"""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.circuit import QuantumCircuit, QuantumRegister

from qdensity.circuits.preparation._common import (
    DATA_REGISTER,
    _append_circuit,
    _check_loader,
    _check_parameter_names,
    _check_sub_unitaries,
)
from qdensity.validation import MAX_SUBUNITARIES, Circuit, SequenceOf, validates

__all__ = ["randomised_circuits"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES),
    loader=[Circuit(min_qubits=1), None],
)
def randomised_circuits(
    sub_unitaries: Sequence[QuantumCircuit], loader: QuantumCircuit | None = None
) -> list[QuantumCircuit]:
    """The randomised density QNN of Fig. 1c: one circuit ``U_k V(x)`` per sub-unitary.

    Each shot runs circuit ``k`` with probability ``alpha_k``; averaged over shots this
    prepares ``rho = sum_k alpha_k U_k |x><x| U_k^dagger`` (eq. 1) without ancillas or
    controlled gates. The shot schedule (how many shots for each ``k``) is the engine's job.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each, parameterised or bound.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits, applied first (e.g. a unary loader template whose data
        parameters are the ``ParameterVector`` ``"x"``). None: the data state is ``|0...0>``.

    Returns
    -------
    list of QuantumCircuit, length K
        Circuit ``k`` has one register ``"data"`` (``n`` qubits), ``V(x)`` then ``U_k``, name
        ``"density_randomised_k"`` and ``metadata["sub_unitary"] = k``.

    Raises
    ------
    TypeError, ValueError
        As in :func:`deterministic_circuit` (distinct parameters sharing a name across the
        sub-unitaries and loader are refused here too, so a name means one parameter in
        every preparation of the model).

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> circuits = randomised_circuits([pyramid(4, parameter_prefix="a"),
    ...                                 pyramid(4, parameter_prefix="b")])
    >>> [c.num_parameters for c in circuits]
    [6, 6]
    """
    circuits = _check_sub_unitaries(sub_unitaries)
    n = circuits[0].num_qubits
    loader = _check_loader(loader, n)
    # Same rule as the ancilla circuits, so that all preparations of one model accept the
    # same inputs and a parameter name means one parameter across them.
    named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
    if loader is not None:
        named.append(("loader", loader))
    _check_parameter_names(named)
    out = []
    for k, circ in enumerate(circuits):
        data = QuantumRegister(n, DATA_REGISTER)
        qc = QuantumCircuit(data, name=f"density_randomised_{k}")
        if loader is not None:
            _append_circuit(qc, loader, list(data))
        _append_circuit(qc, circ, list(data))
        qc.metadata = {"sub_unitary": k}
        out.append(qc)
    return out
