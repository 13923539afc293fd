"""The three preparations of one density QNN together (Fig. 1a, b, c), validated once.

:class:`PreparationCircuits` checks the sub-unitaries, ``alpha`` and loader once and builds
(and caches) the randomised, deterministic and LCU circuits; :func:`prepare_all` is the
one-call form.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.circuits.preparation._common import (
    _check_alpha,
    _check_loader,
    _check_parameter_names,
    _check_sub_unitaries,
)
from qdensity.circuits.preparation.deterministic import deterministic_circuit
from qdensity.circuits.preparation.lcu import lcu_circuit
from qdensity.circuits.preparation.randomised import randomised_circuits
from qdensity.validation import MAX_SUBUNITARIES, Array, Circuit, SequenceOf, validates

__all__ = ["PreparationCircuits", "prepare_all"]


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES), alpha=Array(ndim=1),
    loader=[Circuit(min_qubits=1), None],
)
@dataclass(frozen=True)
class PreparationCircuits:
    """The three preparations of one density QNN (Fig. 1a, b, c), validated once.

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit, length K
        ``U_1 .. U_K`` on ``n`` qubits each.
    alpha : array_like, shape (K,)
        Distribution over the sub-unitaries.
    loader : QuantumCircuit, optional
        ``V(x)`` on ``n`` qubits.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> prep = PreparationCircuits([pyramid(3, parameter_prefix="a"),
    ...                             pyramid(3, parameter_prefix="b")], [0.5, 0.5])
    >>> sorted(prep.prepare_all())
    ['deterministic', 'lcu', 'randomised']
    """

    sub_unitaries: Sequence[QuantumCircuit]  # a tuple once validated
    alpha: np.ndarray
    loader: QuantumCircuit | None = None
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict:
        """The inputs without the prepared circuits (prepared again on use)."""
        return {**{k: v for k, v in list(self.__dict__.items()) if k != "_cache"},
                "_cache": {}}

    def __post_init__(self) -> None:
        circuits = tuple(_check_sub_unitaries(self.sub_unitaries))
        object.__setattr__(self, "sub_unitaries", circuits)
        object.__setattr__(self, "alpha", _check_alpha(self.alpha, len(circuits)))
        object.__setattr__(self, "loader", _check_loader(self.loader, circuits[0].num_qubits))
        named = [(f"sub_unitaries[{k}]", c) for k, c in enumerate(circuits)]
        if self.loader is not None:
            named.append(("loader", self.loader))
        _check_parameter_names(named)

    @property
    def num_sub_unitaries(self) -> int:
        """``K``."""
        return len(self.sub_unitaries)

    @property
    def num_data_qubits(self) -> int:
        """``n``."""
        return self.sub_unitaries[0].num_qubits

    @property
    def randomised(self) -> list[QuantumCircuit]:
        """Fig. 1c circuits (:func:`randomised_circuits`)."""
        if "randomised" not in self._cache:
            self._cache["randomised"] = randomised_circuits(self.sub_unitaries, self.loader)
        return self._cache["randomised"]

    @property
    def deterministic(self) -> QuantumCircuit:
        """Fig. 1b circuit (:func:`deterministic_circuit`)."""
        if "deterministic" not in self._cache:
            self._cache["deterministic"] = deterministic_circuit(
                self.sub_unitaries, self.alpha, self.loader
            )
        return self._cache["deterministic"]

    @property
    def lcu(self) -> QuantumCircuit:
        """Fig. 1a circuit (:func:`lcu_circuit`)."""
        if "lcu" not in self._cache:
            self._cache["lcu"] = lcu_circuit(self.sub_unitaries, self.alpha, self.loader)
        return self._cache["lcu"]

    def prepare_all(self) -> dict[str, QuantumCircuit | list[QuantumCircuit]]:
        """``{"randomised": [K circuits], "deterministic": circuit, "lcu": circuit}``."""
        return {
            "randomised": self.randomised,
            "deterministic": self.deterministic,
            "lcu": self.lcu,
        }


@validates(
    sub_unitaries=SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES),
    alpha=Array(ndim=1), loader=[Circuit(min_qubits=1), None],
)
def prepare_all(
    sub_unitaries: Sequence[QuantumCircuit],
    alpha,
    loader: QuantumCircuit | None = None,
) -> dict[str, QuantumCircuit | list[QuantumCircuit]]:
    """All three preparations of Fig. 1: ``{"randomised", "deterministic", "lcu"}``.

    Parameters
    ----------
    sub_unitaries, alpha, loader
        As in :func:`deterministic_circuit`.

    Returns
    -------
    dict
        ``"randomised"``: list of ``K`` circuits (Fig. 1c); ``"deterministic"``: one circuit
        (Fig. 1b); ``"lcu"``: one circuit (Fig. 1a).

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> out = prepare_all([round_robin(4, parameter_prefix="a")], [1.0])
    >>> len(out["randomised"]), out["lcu"].num_qubits
    (1, 5)
    """
    return PreparationCircuits(sub_unitaries, alpha, loader).prepare_all()
