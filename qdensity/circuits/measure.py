"""Measuring a circuit the house way: qubit ``j`` into clbit ``j`` of one classical register,
so an outcome is the integer ``sum_j b_j 2^j`` (docs/design.md, "Unary encoding")."""

from __future__ import annotations

from qiskit.circuit import CircuitInstruction, ClassicalRegister, Measure, QuantumCircuit

from qdensity.circuits._copying import append_owned
from qdensity.validation import Circuit, Instance, validates

__all__ = ["measured"]


@validates(circuit=Circuit(), name=Instance(str), inplace=Instance(bool))
def measured(circuit: QuantumCircuit, name: str = "meas", *,
             inplace: bool = False) -> QuantumCircuit:
    """A copy of ``circuit`` measuring qubit ``j`` into clbit ``j`` of a new register.

    Parameters
    ----------
    circuit : QuantumCircuit
        Unmeasured circuit.
    name : str
        Classical register name.
    inplace : bool
        Add the register and measurements to ``circuit`` itself (a copy the caller just made)
        instead of to a copy.

    Returns
    -------
    QuantumCircuit
        ``circuit.num_qubits`` qubits and as many clbits (``circuit`` itself when ``inplace``).

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> measured(QuantumCircuit(3)).count_ops()["measure"]
    3
    """
    out = circuit if inplace else circuit.copy()
    creg = ClassicalRegister(circuit.num_qubits, name)
    out.add_register(creg)
    # = out.measure(out.qubits, creg), without its per-call argument broadcasting
    gate = Measure()
    append_owned(out, [CircuitInstruction(gate, (q,), (c,)) for q, c in zip(out.qubits, creg,
                                                                             strict=True)],
                 new=True)
    return out
