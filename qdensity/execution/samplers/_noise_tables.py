"""The errors of a noise model as Kraus superoperators: what the exact noisy sampler
(:mod:`qdensity.execution.samplers.noisy_exact`) reads of a ``NoiseModel``, through public API
only (``NoiseModel.to_dict()``, ``QuantumError.from_dict``, ``qiskit.quantum_info.Kraus``).

A superoperator acts on ``rho`` flattened as ``rho[l, m] -> l * d + m``; an error contributes
``sum_K K (x) conj(K)`` of its Kraus operators.
"""

from __future__ import annotations

import numpy as np
from qiskit.quantum_info import Kraus
from qiskit_aer.noise import NoiseModel, QuantumError

__all__ = ["NoiseTables"]


class NoiseTables:
    """The errors of a ``NoiseModel`` as Kraus superoperators, read once.

    Parameters
    ----------
    noise_model : NoiseModel or None
        None: noiseless.

    Attributes
    ----------
    ok : bool
        False when the model holds an error this module does not apply (see module).

    Examples
    --------
    >>> from qiskit_aer.noise import NoiseModel, ReadoutError, depolarizing_error
    >>> model = NoiseModel()
    >>> model.add_all_qubit_quantum_error(depolarizing_error(0.1, 1), ["x"])
    >>> model.add_readout_error(ReadoutError([[0.9, 0.1], [0.2, 0.8]]), [0])
    >>> tables = NoiseTables(model)
    >>> tables.ok, tables.error("x", (3,)).shape, tables.readout_matrix(0)[1].tolist()
    (True, (4, 4), [0.2, 0.8])
    >>> tables.error("h", (0,)) is None, tables.readout_matrix(1) is None
    (True, True)
    """

    def __init__(self, noise_model: NoiseModel | None):
        # quantum errors stay as read (their dicts) until a lookup needs one: a circuit on a
        # few qubits of a large device converts only the errors of those qubits
        self._errors: list[dict] = []
        self._local: dict[tuple[str, tuple[int, ...]], list[int]] = {}
        self._all_qubit: dict[str, list[int]] = {}
        self._made: dict[int, np.ndarray] = {}
        self._composed: dict[tuple[str, tuple[int, ...]], np.ndarray | None] = {}
        self.readout: dict[int, np.ndarray] = {}
        self.readout_all: np.ndarray | None = None
        self.ok = True
        if noise_model is None:
            return
        index: dict[int, int] = {}
        for e in noise_model.to_dict()["errors"]:
            kind = e.get("type")
            if kind == "qerror":
                key = id(e["instructions"])
                if key not in index:
                    index[key] = len(self._errors)
                    self._errors.append(e)
                i = index[key]
                for op in e["operations"]:
                    if "gate_qubits" in e:
                        for g in e["gate_qubits"]:
                            k = (op, tuple(int(q) for q in g))
                            self._local.setdefault(k, []).append(i)
                    else:
                        self._all_qubit.setdefault(op, []).append(i)
            elif kind == "roerror":
                probs = np.asarray(e["probabilities"], dtype=float)
                if probs.shape != (2, 2):
                    self.ok = False  # correlated readout: left to Aer
                    return
                if "gate_qubits" in e:
                    for g in e["gate_qubits"]:
                        self.readout[int(g[0])] = probs
                else:
                    self.readout_all = probs
            else:
                self.ok = False
                return

    def _superop(self, i: int) -> np.ndarray:
        if i not in self._made:
            self._made[i] = _superop_of(QuantumError.from_dict(self._errors[i]))
        return self._made[i]

    def error(self, name: str, qubits: tuple[int, ...]) -> np.ndarray | None:
        """The superoperator of the error after ``name`` on ``qubits`` (None: no error): the
        qubit-specific errors of the instruction in the model's order, else its all-qubit
        ones (as Aer applies them)."""
        key = (name, tuple(qubits))
        if key not in self._composed:
            found = self._local.get(key) or self._all_qubit.get(name) or []
            sup = None
            for i in found:  # a later error acts after an earlier one
                sup = self._superop(i) if sup is None else self._superop(i) @ sup
            self._composed[key] = sup
        return self._composed[key]

    def readout_matrix(self, qubit: int) -> np.ndarray | None:
        """``P[true, read]`` of ``qubit``'s readout error (None: none)."""
        found = self.readout.get(qubit)
        return found if found is not None else self.readout_all


def _superop_of(error: QuantumError) -> np.ndarray:
    """``sum_K K (x) conj(K)``: acts on ``rho`` flattened as ``rho[l, m] -> index l * d + m``."""
    return _kraus_superop(Kraus(error.to_quantumchannel()).data)


def _kraus_superop(kraus) -> np.ndarray:
    return np.sum([np.kron(K, np.conj(K)) for K in kraus], axis=0)
