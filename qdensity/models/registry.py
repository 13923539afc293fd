"""The registries of the model layer: decompositions and mixtures, one entry per name.

A :class:`DecompositionKind` cuts one circuit into the sub-unitaries of a density QNN (paper
eq. 2, Supp. B/C: moments, cyclic moments, odd/even); a :class:`MixtureKind` makes the
distribution ``alpha`` over them (eq. 1: fixed, a trainable softmax, or a data-dependent gate).
The estimators (``decomposition=``, ``mixture=``), their saved files, ``qdensity sweep`` and
:func:`~qdensity.models.warm_start.warm_start` read these entries; the readouts are
:data:`qdensity.models.density.READOUTS`.

Examples
--------
>>> from qdensity.circuits.ansatze import round_robin
>>> subs = DECOMPOSITIONS["layers"].split(round_robin(4), depth=2)
>>> len(subs), MIXTURES["softmax"].build(4, len(subs), None).num_params
(2, 2)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from qiskit import QuantumCircuit

from qdensity.analysis.structure import moments
from qdensity.models.decompositions import by_moments, cyclic_moments, odd_even
from qdensity.models.mixtures import FixedMixture, GatedMixture, Mixture, SoftmaxMixture
from qdensity.validation import CallableC, Instance, validates

__all__ = ["DecompositionKind", "MixtureKind", "DECOMPOSITIONS", "MIXTURES"]


@validates(name=Instance(str), split=CallableC("f(circuit, depth) -> list of QuantumCircuit"),
           angle_copies=Instance(bool))
@dataclass(frozen=True)
class DecompositionKind:
    """A named way to cut a circuit into sub-unitaries.

    Attributes
    ----------
    name : str
        The estimators' ``decomposition=`` value.
    split : callable
        ``split(circuit, depth) -> list[QuantumCircuit]``: the sub-unitaries.
    angle_copies : bool
        Whether each of the ``depth`` parts carries its own copy of the circuit's angles (the
        cyclic decomposition), so a model has ``depth`` times the circuit's angles.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.registry import DECOMPOSITIONS
    >>> cyclic = DECOMPOSITIONS["cyclic"]
    >>> len(cyclic.split(round_robin(4), 2)), cyclic.num_angles(6, 2)  # K = 3 moments
    (3, 12)
    >>> DECOMPOSITIONS["layers"].num_angles(6, 2)  # shared: the circuit's own 6
    6
    """

    name: str
    split: Callable[[QuantumCircuit, int], list]
    angle_copies: bool = False

    def num_angles(self, circuit_angles: int, depth: int) -> int:
        """Angles of the model built from a circuit with ``circuit_angles`` angles."""
        return circuit_angles * int(depth) if self.angle_copies else circuit_angles

    def __reduce_ex__(self, protocol):
        # a registered entry (its functions are lambdas or closures) pickles and copies as
        # its name: it loads as the entry registered under that name
        if DECOMPOSITIONS.get(self.name) is self:
            return (_registered, ('DECOMPOSITIONS', self.name))
        return super().__reduce_ex__(protocol)


@validates(name=Instance(str), build=CallableC("f(num_qubits, K, seed) -> Mixture or None"),
           from_alpha=[CallableC("f(alpha) -> Mixture"), None], data_dependent=Instance(bool))
@dataclass(frozen=True)
class MixtureKind:
    """A named distribution over the sub-unitaries.

    Attributes
    ----------
    name : str
        The estimators' ``mixture=`` value.
    build : callable
        ``build(num_qubits, K, seed) -> Mixture or None`` (None: ``DensityQNN``'s default,
        the uniform fixed mixture).
    from_alpha : callable or None
        ``from_alpha(alpha) -> Mixture`` starting at a given ``alpha`` (warm start); None if the
        mixture cannot start from one.
    data_dependent : bool
        Whether ``alpha`` depends on the input (a mixture-of-experts gate).

    Examples
    --------
    >>> from qdensity.models.registry import MIXTURES
    >>> gate = MIXTURES["moe"].build(4, 3, 0)  # 4 features, 3 sub-unitaries: W (3, 4), b (3,)
    >>> MIXTURES["moe"].data_dependent, type(gate).__name__, gate.num_params
    (True, 'GatedMixture', 15)
    >>> MIXTURES["fixed"].build(4, 3, None) is None  # DensityQNN's uniform default
    True
    """

    name: str
    build: Callable[[int, int, object], Mixture | None]
    from_alpha: Callable[[np.ndarray], Mixture] | None = None
    data_dependent: bool = False

    def __reduce_ex__(self, protocol):
        # a registered entry (its functions are lambdas or closures) pickles and copies as
        # its name: it loads as the entry registered under that name
        if MIXTURES.get(self.name) is self:
            return (_registered, ('MIXTURES', self.name))
        return super().__reduce_ex__(protocol)


def _registered(registry: str, name: str):
    """The entry ``name`` of ``DECOMPOSITIONS`` or ``MIXTURES`` (what a registered entry
    pickles to)."""
    return DECOMPOSITIONS[name] if registry == "DECOMPOSITIONS" else MIXTURES[name]


def _num_moments(circuit: QuantumCircuit) -> int:
    return max(len(moments(circuit)), 1)


def _layers(circuit: QuantumCircuit, depth: int) -> list:
    return by_moments(circuit, min(depth, _num_moments(circuit))).sub_unitaries


def _cyclic(circuit: QuantumCircuit, depth: int) -> list:
    return cyclic_moments(circuit, min(depth, _num_moments(circuit))).sub_unitaries


#: Decompositions by name (the estimators' ``decomposition=``), in the order listings show.
DECOMPOSITIONS: dict[str, DecompositionKind] = {d.name: d for d in (
    DecompositionKind("layers", _layers),
    DecompositionKind("cyclic", _cyclic, angle_copies=True),
    DecompositionKind("odd_even", lambda circuit, depth: odd_even(circuit).sub_unitaries),
    DecompositionKind("none", lambda circuit, depth: [circuit]),
)}


def _gated(activation: str | None) -> Callable:
    def build(num_qubits: int, k: int, seed) -> GatedMixture:
        return GatedMixture(num_qubits, k, activation=activation, seed=seed)
    return build


#: Mixtures by name (the estimators' ``mixture=``), in the order listings show.
MIXTURES: dict[str, MixtureKind] = {m.name: m for m in (
    MixtureKind("softmax", lambda n, k, seed: SoftmaxMixture(k),
                from_alpha=lambda alpha: SoftmaxMixture(alpha=alpha)),
    MixtureKind("fixed", lambda n, k, seed: None, from_alpha=FixedMixture),
    MixtureKind("moe", _gated(None), data_dependent=True),
    MixtureKind("moe_gelu", _gated("gelu"), data_dependent=True),
)}


