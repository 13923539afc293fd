"""An ``AerSimulator`` that hands Aer only the noise of the qubits a job acts on, on public API.

Aer serialises the whole noise model it runs with on every ``run`` (``NoiseModel.to_dict`` with
a JSON round trip in Python, then a parse in C++), whatever the circuit: a device's model holds
one depolarising and one thermal-relaxation channel per gate and qubit, so a 27-qubit snapshot
pays ~0.2 s per call (a 27-qubit ``GenericBackendV2``'s model ~1.5 s) for an 8-qubit circuit
whose simulation takes 0.03-0.15 s (qiskit-aer 0.18, one thread;
``benchmarks/bench_served_noise.py``). Aer then simulates only the active qubits (its
truncation), so the errors of gates on other qubits are never applied.

:class:`ServedNoiseSimulator` therefore runs each job with Aer's public ``noise_model`` run
option set to a *served model*: a ``NoiseModel`` holding the errors whose qubits all lie among
the job's active qubits (and every error not tied to qubits), in the order of the device's
model, built once per (noise model, set of active qubits) with public API (``to_dict`` of the
device's model, ``QuantumError.from_dict``, ``ReadoutError``, ``add_quantum_error``,
``add_all_qubit_quantum_error``, ``add_readout_error``, ``add_all_qubit_readout_error``). A
served model keeps its own serialisation (``to_dict(serializable=True)``) until one of those
public ``add_*``/``reset`` methods changes it, so a call pays for its qubits' errors once, not
per run. It only overrides public methods (``run``, ``to_dict``, the ``add_*``); the kept
serialisation saves time only because Aer reads the model through ``to_dict``: were that to
change, the served model would still be the same channel, only slower to hand over.

Measured (``benchmarks/bench_served_noise.py``, an 8-qubit chain, 256 shots, one thread, 2
shared cores): a run costs 0.03-0.15 s of CPU against plain ``AerSimulator.from_backend``'s
0.19-0.31 s on ``fake_kolkata`` (0.15-0.41x) and 1.4-1.6 s on a 27-qubit ``GenericBackendV2``
(0.04-0.10x), as with the private compile hook this replaces; serialising the served model per
run instead of keeping it cost 0.02-0.04 s more per run (1.35-1.7x). A new set of qubits costs
its served model once (0.05-0.4 s).

The served channel is the device model's channel on the active qubits: every served model is
checked against the device model's errors when it is built (the same errors, instructions,
qubits and order; probabilities equal to 1e-12 relative, as ``QuantumError`` renormalises
them), and the device's whole model is passed instead when the check fails (an error
``QuantumError.from_dict`` cannot read back), or when a circuit holds a ``delay`` (a device
model relaxes delays with a noise pass that ``to_dict`` does not carry). Counts for a seed are
those of the whole model (bit for bit unless a draw falls within rounding of a cumulative
probability). With the ``matrix_product_state`` method the circuits also go on the line of
:func:`~qdensity.hardware._mps_line.line_order`, their served noise renumbered with them.

The device's model is read (``to_dict``) once per model object: change a simulator's noise with
``set_options(noise_model=...)``, not by editing the model it holds in place.
"""

from __future__ import annotations

import numbers
import threading
import weakref

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.exceptions import QiskitError
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel, QuantumError, ReadoutError

from qdensity.hardware._mps_line import line_order, relabelled, renumbered

__all__: list[str] = []

_NOT_QUBIT_WORK = frozenset({"barrier"})
#: Instructions for which (in any circuit of a job) the device's whole model is served.
_WHOLE_MODEL_FOR = frozenset({"delay"})
_MAX_SERVED = 64  # qubit sets kept per noise model
#: Relative tolerance of the check of a served model's probabilities (see module).
_RTOL = 1e-12
_NUMBERS = (numbers.Number, np.number)
#: id(noise model) -> (weak reference, its ``to_dict()``, {qubits or positions: served model
#: or None, None meaning "serve the whole model"}, its rebuilt errors (``served_model``'s
#: ``made``))
_SERVED: dict[int, tuple] = {}
_SERVED_LOCK = threading.Lock()  # see _served


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


def _active(circuits: list) -> frozenset[int] | None:
    """Active qubits of all ``circuits``; None when one is not a ``QuantumCircuit`` or holds
    an instruction of :data:`_WHOLE_MODEL_FOR`."""
    used: set[int] = set()
    for circ in circuits:
        if not isinstance(circ, QuantumCircuit):
            return None
        if any(inst.name in _WHOLE_MODEL_FOR for inst in circ.data):
            return None
        used |= active_indices(circ)
    return frozenset(used)


def restricted_errors(serialised: dict, qubits: frozenset[int]) -> dict:
    """The errors of a serialised noise model that can act on ``qubits`` alone.

    Parameters
    ----------
    serialised : dict
        ``NoiseModel.to_dict()`` (or ``to_dict(serializable=True)``).
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


class ServedModel(NoiseModel):
    """A ``NoiseModel`` that keeps its serialisation until changed through its public methods.

    ``to_dict(serializable=True)`` is computed once and reused (a new top-level dict and list
    per call, the error entries shared: Aer only reads them); ``add_*`` and ``reset`` drop it.
    Build it with public ``NoiseModel`` methods only; never change its private state.
    """

    def __init__(self, basis_gates=None):
        self._qd_serialised: dict | None = None
        super().__init__(basis_gates=basis_gates)

    def to_dict(self, serializable: bool = False) -> dict:
        """``NoiseModel.to_dict``, the serialisable form computed once (see class)."""
        if not serializable:
            return super().to_dict()
        if self._qd_serialised is None:
            self._qd_serialised = super().to_dict(serializable=True)
        return {**self._qd_serialised, "errors": list(self._qd_serialised["errors"])}

    def reset(self):
        self._qd_serialised = None
        return super().reset()

    def add_basis_gates(self, instructions):
        self._qd_serialised = None
        return super().add_basis_gates(instructions)

    def add_all_qubit_quantum_error(self, error, instructions, warnings=True):
        self._qd_serialised = None
        return super().add_all_qubit_quantum_error(error, instructions, warnings=warnings)

    def add_quantum_error(self, error, instructions, qubits, warnings=True):
        self._qd_serialised = None
        return super().add_quantum_error(error, instructions, qubits, warnings=warnings)

    def add_all_qubit_readout_error(self, error, warnings=True):
        self._qd_serialised = None
        return super().add_all_qubit_readout_error(error, warnings=warnings)

    def add_readout_error(self, error, qubits, warnings=True):
        self._qd_serialised = None
        return super().add_readout_error(error, qubits, warnings=warnings)


def _same(a, b) -> bool:
    """``a`` equals ``b`` (parts of ``NoiseModel.to_dict()``), numbers to :data:`_RTOL`
    relative, ``"id"`` entries ignored (a rebuilt ``QuantumError`` gets a new one)."""
    if isinstance(a, dict):
        return (isinstance(b, dict) and a.keys() == b.keys()
                and all(k == "id" or _same(a[k], b[k]) for k in a))
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.allclose(a, b, rtol=_RTOL, atol=0))
    if isinstance(a, _NUMBERS) and isinstance(b, _NUMBERS):
        x, y = np.asarray(a, dtype=complex), np.asarray(b, dtype=complex)
        return bool(x == y or abs(x - y) <= _RTOL * max(abs(x), abs(y)))
    return bool(a == b)


def served_model(errors: dict, basis_gates, made: dict | None = None) -> ServedModel | None:
    """A :class:`ServedModel` holding ``errors``, or None when one cannot be read back exactly.

    Parameters
    ----------
    errors : dict
        ``{"errors": [...]}`` in the form of ``NoiseModel.to_dict()`` (not serialisable), e.g.
        :func:`restricted_errors` of a device's model.
    basis_gates : list of str
        The device model's ``basis_gates``.
    made : dict, optional
        ``QuantumError``s rebuilt before, by ``id`` of their entry's ``instructions`` list
        (shared by every restriction of one ``to_dict()``); filled in here.

    Returns
    -------
    ServedModel or None
        None when an entry is of an unknown type, cannot be rebuilt by
        ``QuantumError.from_dict``/``ReadoutError``, or the rebuilt model's ``to_dict()`` is
        not ``errors`` (to :data:`_RTOL` in the probabilities, ids aside).
    """
    model = ServedModel(basis_gates=list(basis_gates))
    made = {} if made is None else made
    try:
        for e in errors["errors"]:
            if e.get("type") == "qerror":
                key = id(e["instructions"])
                if key not in made:
                    made[key] = (e["instructions"], QuantumError.from_dict(e))
                qerr = made[key][1]
                if "gate_qubits" in e:
                    for g in e["gate_qubits"]:
                        model.add_quantum_error(qerr, e["operations"], g, warnings=False)
                else:
                    model.add_all_qubit_quantum_error(qerr, e["operations"], warnings=False)
            elif e.get("type") == "roerror":
                rerr = ReadoutError(e["probabilities"])
                if "gate_qubits" in e:
                    for g in e["gate_qubits"]:
                        model.add_readout_error(rerr, g, warnings=False)
                else:
                    model.add_all_qubit_readout_error(rerr, warnings=False)
            else:
                return None
    except (QiskitError, ValueError, TypeError, KeyError):  # NoiseError is a QiskitError
        return None
    return model if _same(model.to_dict()["errors"], errors["errors"]) else None


def _served(source: NoiseModel, qubits: frozenset[int], position: dict[int, int] | None = None
            ) -> NoiseModel:
    """What Aer runs with for a job on ``qubits`` (renumbered by ``position`` when given):
    ``source``'s served model, built once per qubit set (``source`` itself where none can be
    built). ``source.to_dict()`` is read once per model object and dropped with it.

    One thread at a time: Aer's primitive jobs call this from their own threads, and two
    threads reading ``to_dict()`` of one shared model at once deadlocked inside Qiskit
    (both waiting in ``QuantumCircuit.find_bit``; seen once in a full test run)."""
    with _SERVED_LOCK:
        key = id(source)
        entry = _SERVED.get(key)
        if entry is None or entry[0]() is not source:
            def drop(_: object, k: int = key) -> None:
                _SERVED.pop(k, None)

            entry = (weakref.ref(source, drop), source.to_dict(), {}, {})
            _SERVED[key] = entry
        served = entry[2]
        at = qubits if position is None else tuple(sorted(position.items()))
        if at not in served:
            if len(served) >= _MAX_SERVED:
                served.clear()
            errors = restricted_errors(entry[1], qubits)
            if position is not None:
                errors = renumbered(errors, position)
            served[at] = served_model(errors, source.basis_gates, entry[3])
        out = served[at]
        return source if out is None else out


class ServedNoiseSimulator(AerSimulator):
    """``AerSimulator`` serving Aer the noise of each job's active qubits (see module); with
    the ``matrix_product_state`` method the circuits also go on the line of
    :func:`~qdensity.hardware._mps_line.line_order`, their noise renumbered with them."""

    def run(self, circuits, parameter_binds=None, **run_options):
        """``AerSimulator.run`` with the served model of the circuits' active qubits as the
        ``noise_model`` run option (that option, when given, is the model served)."""
        source = run_options.get("noise_model", getattr(self.options, "noise_model", None))
        many = circuits if isinstance(circuits, list) else [circuits]
        qubits = _active(many) if isinstance(source, NoiseModel) else None
        if qubits is None:
            return super().run(circuits, parameter_binds=parameter_binds, **run_options)
        if run_options.get("method", self.options.method) == "matrix_product_state":
            position = line_order(many, qubits)
            if position is not None:
                return super().run([relabelled(c, position) for c in many],
                                   parameter_binds=parameter_binds,
                                   **{**run_options,
                                      "noise_model": _served(source, qubits, position)})
        return super().run(circuits, parameter_binds=parameter_binds,
                           **{**run_options, "noise_model": _served(source, qubits)})
