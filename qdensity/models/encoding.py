"""Data encodings ``V(x)`` of a density QNN: ``rho(x) = V(x)|0><0|V(x)^dagger`` (paper eq. 1).

:class:`Encoding` pairs a loader circuit with the map from data to its parameters: the unary
amplitude encoding of the orthogonal (RBS) models, or the angle encoding of the equivariant
experiments. :class:`qdensity.models.density.DensityQNN` takes one as its ``encoding``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity.validation import (
    MAX_ROWS,
    CallableC,
    Circuit,
    Interval,
    Options,
    check_finite_array,
    check_num_qubits,
    validates,
)

__all__ = ["Encoding"]


def _as_float(X) -> np.ndarray:
    """The angle encoding's data map (module level, so encodings and models pickle)."""
    return np.asarray(X, dtype=float)


@validates(
    circuit=Circuit(min_qubits=1), transform=CallableC('a callable X (B, d) -> values (B, P_enc)'),
    num_features=Interval(int, 1, MAX_ROWS), kind=Options(('other', 'unary', 'angle')),
    jacobian=[CallableC('a callable X (B, d) -> (B, P_enc, d)'), None],
)
@dataclass
class Encoding:
    """A data loader ``V(x)``: a circuit with data parameters and the map from data to them.

    Attributes
    ----------
    circuit : QuantumCircuit
        ``n`` qubits; its free parameters are set by ``transform``.
    transform : callable
        ``X (B, d) -> values (B, P_enc)`` in ``circuit.parameters`` order.
    num_features : int
        d.
    kind : str
        ``"unary"`` (amplitude encoding on the unary basis) or ``"other"``.
    jacobian : callable, optional
        ``X (B, d) -> (B, P_enc, d)``, the derivative of ``transform``: input gradients
        through an encoding of another kind need it (the angle and unary encodings have theirs
        built in, :mod:`qdensity.gradients.inputs`).

    Examples
    --------
    The unary loader puts ``x / ||x||`` on the states ``e_j`` (one qubit set, index ``2^j``):

    >>> import numpy as np
    >>> from qiskit.quantum_info import Statevector
    >>> from qdensity.models import Encoding
    >>> enc, x = Encoding.unary(4), np.array([[1.0, 2.0, 3.0, 4.0]])
    >>> angles = enc.values(x)  # 3 RBS angles
    >>> psi = Statevector(enc.circuit.assign_parameters(angles[0])).data
    >>> angles.shape, bool(np.allclose(psi[[1, 2, 4, 8]], x[0] / np.linalg.norm(x)))
    ((1, 3), True)
    """

    circuit: QuantumCircuit
    transform: Callable[[np.ndarray], np.ndarray]
    num_features: int
    kind: str = "other"
    jacobian: Callable[[np.ndarray], np.ndarray] | None = None

    @classmethod
    def unary(cls, num_features: int, layout: str = "parallel") -> Encoding:
        """Unary amplitude encoding ``|x> = sum_j x_j/||x|| |e_j>`` (parallel loader by default).

        Parameters
        ----------
        num_features : int
            d >= 2 = number of qubits.
        layout : {"parallel", "diagonal", "semi_diagonal"}
        """
        from qdensity.circuits.loaders import loader_angles, unary_loader_template

        check_num_qubits(num_features, "num_features", minimum=2)  # one qubit per feature
        template = unary_loader_template(num_features, layout=layout, parameter_prefix="φ")
        return cls(template, partial(loader_angles, layout=layout), num_features, "unary")

    @classmethod
    def angle(cls, num_qubits: int) -> Encoding:
        """Angle encoding ``R_y(pi x_i / 2)`` on qubit i (paper, equivariant experiments)."""
        from qdensity.circuits.ansatze.equivariant import angle_encoding

        check_num_qubits(num_qubits)
        circ = angle_encoding(num_qubits)
        return cls(circ, _as_float, num_qubits, "angle")

    def values(self, X) -> np.ndarray:
        """Encoding parameter rows for data ``X`` (B, d) -> (B, P_enc)."""
        X = np.atleast_2d(check_finite_array(X, "X"))
        if X.ndim != 2 or X.shape[0] == 0 or X.shape[1] != self.num_features:
            raise ValueError(f"X must have {self.num_features} features, got shape {X.shape}")
        return np.atleast_2d(self.transform(X))
