"""An ``AerSimulator`` that hands Aer only the noise of the qubits a job acts on, serialised once.

Aer serialises the whole noise model on every ``run`` (``NoiseModel.to_dict`` with a JSON round
trip in Python, then a parse in C++), whatever the circuit: a device's model holds one
depolarising and one thermal-relaxation channel per gate and qubit, so a 27-qubit snapshot pays
~0.3 s per call for an 8-qubit circuit whose simulation takes 0.06 s (qiskit-aer 0.18, 2 cores).
Aer then simulates only the active qubits (its truncation), so the errors of gates on other
qubits are never applied: :class:`ServedNoiseSimulator` passes Aer the errors whose qubits all
lie among the job's active qubits (and every error not tied to qubits), from a serialisation
made once per noise model (shared by every simulator that holds it, dropped with the model) and
kept per set of active qubits. The simulated channel is the same and so, for a seed, are the
counts.

The noise model is read once per set of active qubits: change a simulator's noise with
``set_options(noise_model=...)``, not by editing the model it holds in place.
"""

from __future__ import annotations

import weakref

from qiskit.circuit import QuantumCircuit
from qiskit_aer import AerSimulator

from qdensity.hardware._mps_line import line_order, relabelled, renumbered

__all__: list[str] = []

_NOT_QUBIT_WORK = frozenset({"barrier"})
_MAX_SERVED = 64  # qubit sets kept per noise model
#: id(noise model) -> (weak reference, its serialisation, {qubits: restricted errors})
_SERIALISED: dict[int, tuple] = {}


def active_indices(circuit: QuantumCircuit) -> frozenset[int]:
    """Indices of the qubits an instruction of ``circuit`` other than ``barrier`` acts on.

    Parameters
    ----------
    circuit : QuantumCircuit

    Returns
    -------
    frozenset of int
    """
    used: set = set()
    for inst in circuit.data:  # ``inst.name``: no Python object for the operation
        if inst.name not in _NOT_QUBIT_WORK:
            used.update(inst.qubits)
    return frozenset(circuit.find_bit(q).index for q in used)


def _active(circuits) -> frozenset[int] | None:
    used: set[int] = set()
    for circ in circuits:
        if not isinstance(circ, QuantumCircuit):
            return None
        used |= active_indices(circ)
    return frozenset(used)


class _Serialised:
    """What Aer reads of a noise model when it runs: ``to_dict``."""

    __slots__ = ("errors",)

    def __init__(self, errors: dict):
        self.errors = errors

    def to_dict(self, serializable: bool = False) -> dict:
        return self.errors


def restricted_errors(serialised: dict, qubits: frozenset[int]) -> dict:
    """The errors of a serialised noise model that can act on ``qubits`` alone.

    Parameters
    ----------
    serialised : dict
        ``NoiseModel.to_dict(serializable=True)``.
    qubits : frozenset of int
        Active qubits of the job.

    Returns
    -------
    dict
        ``{"errors": [...]}``: every error without ``gate_qubits`` (all-qubit errors) and every
        error with a ``gate_qubits`` entry inside ``qubits``, in their order.
    """
    keep = [e for e in serialised["errors"]
            if "gate_qubits" not in e or any(set(g) <= qubits for g in e["gate_qubits"])]
    return {**serialised, "errors": keep}


def _served(source, qubits: frozenset[int], position: dict[int, int] | None = None
            ) -> _Serialised:
    """``source``'s errors on ``qubits`` (renumbered by ``position`` when given); the whole
    model is serialised once per model object (shared by every simulator holding it) and
    dropped with it."""
    key = id(source)
    entry = _SERIALISED.get(key)
    if entry is None or entry[0]() is not source:
        def drop(_: object, k: int = key) -> None:
            _SERIALISED.pop(k, None)

        entry = (weakref.ref(source, drop),
                 source.to_dict(serializable=True), {})
        _SERIALISED[key] = entry
    served = entry[2]
    at = qubits if position is None else tuple(sorted(position.items()))
    if at not in served:
        if len(served) >= _MAX_SERVED:
            served.clear()
        errors = restricted_errors(entry[1], qubits)
        served[at] = _Serialised(errors if position is None else renumbered(errors, position))
    return served[at]


class ServedNoiseSimulator(AerSimulator):
    """``AerSimulator`` serving Aer the noise of each job's active qubits (see module); with
    the ``matrix_product_state`` method the circuits also go on the line of
    :func:`~qdensity.hardware._mps_line.line_order`, their noise renumbered with them."""

    def _compile(self, circuits, **run_options):
        out = super()._compile(circuits, **run_options)
        source = getattr(self.options, "noise_model", None)
        if not (isinstance(out, tuple) and len(out) == 2) or source is None or out[1] is not source:
            return out  # no noise, or Aer added the circuits' own error instructions to a copy
        compiled, _ = out
        compiled = compiled if isinstance(compiled, list) else [compiled]
        qubits = _active(compiled)
        if qubits is None:
            return out
        if run_options.get("method", self.options.method) == "matrix_product_state":
            position = line_order(compiled, qubits)
            if position is not None:
                return ([relabelled(c, position) for c in compiled],
                        _served(source, qubits, position))
        return compiled, _served(source, qubits)
