"""Hamming-weight-preserving two-mode gates: RBS and FBS (paper eq. 8, Supp. E eq. 24-25).

Both are real ``Gate`` subclasses with an exact matrix, a gate-level ``_define`` in standard
gates, and an ``inverse``; any transpiler unrolls them. Their matrix, decomposition, generator,
shift rule and Hamming-weight behaviour are the entries ``rbs`` and ``fbs`` of the gate registry
(:mod:`qdensity.analysis.gate_registry`), which every layer reads.

Conventions (docs/design.md, "Conventions"):

* ``qc.append(RBSGate(theta), [i, j])`` has, in Qiskit's operator convention (basis index
  ``q_i + 2 q_j``), the paper's matrix ``[[1,0,0,0],[0,c,-s,0],[0,s,c,0],[0,0,0,1]]``. On unary
  amplitudes it rotates the ``(i, j)`` plane by ``+theta``:
  ``y_i -> c y_i - s y_j``, ``y_j -> s y_i + c y_j``. ``RBS(theta) = exp(-i theta Q)``,
  ``Q = (X_i Y_j - Y_i X_j) / 2`` (the paper's ``(Y (x) X - X (x) Y)/2`` read big-endian).
* ``FBSGate(theta, m)`` acts on ``m`` contiguous qubits ``[i, ..., j]`` as ``RBS((-1)^p theta)``
  on ``(i, j)``, where ``p`` is the parity of the qubits strictly between them.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import Gate
from qiskit.circuit.parameterexpression import ParameterExpression, ParameterValueType

from qdensity.analysis.gate_registry import FBS, RBS
from qdensity.validation import (
    Instance,
    Interval,
    Qubits,
    validates,
)

__all__ = ["RBSGate", "FBSGate", "rbs_matrix", "fbs_matrix"]


@validates(theta=Interval(float))
def rbs_matrix(theta: float) -> np.ndarray:
    """The 4 x 4 RBS matrix (paper eq. 8) in Qiskit's little-endian convention.

    Parameters
    ----------
    theta : float
        Rotation angle.

    Returns
    -------
    numpy.ndarray, shape (4, 4)
        ``[[1,0,0,0],[0,c,-s,0],[0,s,c,0],[0,0,0,1]]`` with ``c = cos(theta)``,
        ``s = sin(theta)``, basis index ``q_0 + 2 q_1``.

    Examples
    --------
    >>> import numpy as np
    >>> rbs_matrix(np.pi / 2).round(12).real.tolist()
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    """
    return RBS.matrix([float(theta)], 2)


@validates(theta=Interval(float), num_qubits=Interval(
    int, 2, 12, why="a dense 2**m x 2**m matrix; circuits use FBSGate, which needs none"))
def fbs_matrix(theta: float, num_qubits: int) -> np.ndarray:
    """The ``2^m x 2^m`` FBS matrix on ``m`` contiguous qubits (Supp. E.2, eq. 24).

    Parameters
    ----------
    theta : float
        Rotation angle.
    num_qubits : int
        Width ``m >= 2`` of the block; the gate couples its first and last qubit.

    Returns
    -------
    numpy.ndarray, shape (2**m, 2**m)
        Acts as ``RBS((-1)^p theta)`` on qubits ``(0, m-1)``, ``p`` the parity of qubits
        ``1 .. m-2``; basis index ``sum_q b_q 2^q``.

    Examples
    --------
    With nothing between the pair it is the RBS matrix:

    >>> import numpy as np
    >>> fbs_matrix(0.3, 3).shape, np.allclose(fbs_matrix(0.3, 2), rbs_matrix(0.3))
    ((8, 8), True)
    """
    return FBS.matrix([float(theta)], int(num_qubits))


def _angle(theta):
    """A declared gate angle as a gate parameter: a ``ParameterExpression`` as is, a real
    number as a float."""
    return theta if isinstance(theta, ParameterExpression) else float(theta)


@validates(
    theta=[Interval(float), Instance(ParameterExpression, 'Parameter or ParameterExpression')],
    label=[Instance(str), None],
)
class RBSGate(Gate):
    r"""Reconfigurable beam splitter ``RBS(theta) = exp(-i theta Q)`` (paper eq. 8).

    A Givens rotation on the Hamming-weight-1 subspace of two qubits:

    .. math::

        \mathrm{RBS}(\theta) = e^{-i \theta Q} = \begin{pmatrix} 1 & 0 & 0 & 0 \\
        0 & \cos\theta & -\sin\theta & 0 \\ 0 & \sin\theta & \cos\theta & 0 \\
        0 & 0 & 0 & 1 \end{pmatrix}, \qquad Q = \tfrac{1}{2}(Y \otimes X - X \otimes Y).

    On unary amplitudes of qubits ``(i, j)``: ``y_i -> cos(theta) y_i - sin(theta) y_j``,
    ``y_j -> sin(theta) y_i + cos(theta) y_j``. Equal to ``XXPlusYYGate(2 theta, pi/2)``.

    Its definition uses two CZ gates (the minimum):
    ``(H (x) H) CZ (RY(theta) (x) RY(-theta)) CZ (H (x) H)``.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity import RBSGate
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.append(RBSGate(0.3), [0, 1])
    """

    def __init__(self, theta: ParameterValueType, label: str | None = None):
        super().__init__(RBS.name, 2, [_angle(theta)], label=label)

    def _define(self) -> None:
        self.definition = RBS.decomposition(self.params, 2)

    def inverse(self, annotated: bool = False) -> RBSGate:
        """Return ``RBS(-theta)``."""
        return RBSGate(-self.params[0])

    def __deepcopy__(self, memo=None) -> RBSGate:
        """``copy.deepcopy`` (and ``Instruction.copy``, ``QuantumCircuit.copy``): the same
        gate with its own parameter list and no definition yet (it is a function of
        ``theta`` alone, rebuilt by :meth:`_define` when asked for). Angles and Parameters are
        immutable, so the list is copied, not its entries: about 0.7 us against 3.2 us for
        ``Instruction.__deepcopy__`` (a ``copy.copy``, a ``copy.deepcopy`` of the parameter
        list and of the definition), the cost of every circuit copy of an RBS circuit.
        """
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.params = list(self.params)  # the setter makes the new list
        new.definition = None
        return new

    def __array__(self, dtype=None, copy=None):
        if copy is False:
            raise ValueError("unable to avoid copy while creating an array as requested")
        mat = rbs_matrix(float(self.params[0]))
        return mat.astype(dtype) if dtype is not None else mat


@validates(
    theta=[Interval(float), Instance(ParameterExpression, 'Parameter or ParameterExpression')],
    num_qubits=Qubits(2), label=[Instance(str), None],
)
class FBSGate(Gate):
    r"""Fermionic beam splitter on a contiguous block of ``num_qubits`` qubits (Supp. E.2).

    Couples the block's first and last qubit ``(i, j)``: acts as ``RBS((-1)^p theta)`` on them,
    where ``p`` is the parity of the ``num_qubits - 2`` qubits strictly between. It equals RBS
    on adjacent qubits and on every unary input; a circuit of FBS gates acts on the
    Hamming-weight-k subspace as the k-th compound of the orthogonal matrix of the same circuit
    with RBS gates.

    Defined as in eq. 25: the parity of the inner qubits is computed onto qubit ``i + 1`` with
    CNOTs, a CZ from it conjugates the RBS (``Z RBS(theta) Z = RBS(-theta)``), and the parity is
    uncomputed.

    Parameters
    ----------
    theta : float or Parameter
        Rotation angle.
    num_qubits : int
        Width of the contiguous block, ``>= 2``.

    Examples
    --------
    On 3 qubits it is an RBS on the outer pair whose angle flips sign with the middle qubit:

    >>> import numpy as np
    >>> from qiskit.quantum_info import Operator
    >>> np.allclose(Operator(FBSGate(0.3, 3)).data, fbs_matrix(0.3, 3))
    True
    """

    def __init__(self, theta: ParameterValueType, num_qubits: int, label: str | None = None):
        super().__init__(FBS.name, int(num_qubits), [_angle(theta)], label=label)

    def _define(self) -> None:
        self.definition = FBS.decomposition(self.params, self.num_qubits, core=RBSGate)

    def inverse(self, annotated: bool = False) -> FBSGate:
        """Return ``FBS(-theta)`` on the same block."""
        return FBSGate(-self.params[0], self.num_qubits)

    def __array__(self, dtype=None, copy=None):
        if copy is False:
            raise ValueError("unable to avoid copy while creating an array as requested")
        mat = fbs_matrix(float(self.params[0]), self.num_qubits)
        return mat.astype(dtype) if dtype is not None else mat
