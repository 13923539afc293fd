"""What a :class:`~qdensity.models.density.DensityQNN` derives from its structure, kept until
the structure changes.

Compiled unary circuits, exact engines, commuting-gradient analyses and the like depend on the
sub-unitaries, the encoding, the readout and the observable, not on the angles or the data. They
live in one store on the model, keyed on a fingerprint of exactly those: setting
``model.observable`` (or the circuits, the encoding, the readout) empties the store, so the
next answer is a fresh model's. The fingerprint holds the identity of each circuit with its
instruction and parameter counts (an appended gate changes it), the encoding's identity and its
circuit's, the readout, and the observable's Pauli bits, phases and coefficients; the mixture
and the angles are read afresh on every call and are not in it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["structure_key", "DerivedStore"]


def structure_key(model) -> tuple:
    """A fingerprint of what the model's derived values depend on (see the module)."""
    subs = model.sub_unitaries
    enc = model.encoding
    obs = model.observable
    paulis = obs.paulis
    return (tuple((id(c), len(c.data), c.num_parameters) for c in subs),
            None if enc is None else (id(enc), id(enc.circuit), len(enc.circuit.data)),
            model.readout, paulis.x.tobytes(), paulis.z.tobytes(), paulis.phase.tobytes(),
            np.asarray(obs.coeffs).tobytes(), obs.num_qubits)


class DerivedStore:
    """Named dicts of derived values, emptied whenever the fingerprint changes."""

    def __init__(self):
        self.key: tuple | None = None
        self.stores: dict[str, dict] = {}

    def store(self, key: tuple, name: str) -> dict:
        """The dict called ``name`` for a model whose fingerprint is ``key``."""
        if key != self.key:
            self.key, self.stores = key, {}
        return self.stores.setdefault(name, {})

    def __getstate__(self):  # a copy or an unpickled model derives again
        return {"derived": "again"}

    def __setstate__(self, state):
        self.key, self.stores = None, {}
