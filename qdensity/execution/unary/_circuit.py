"""The compiled form of an RBS / FBS circuit for the unary engine: its Givens rotations
(gate pairs, the parameter and affine map of each angle) and their schedule in layers of
disjoint rotations. Built by :func:`qdensity.execution.unary.compile_unary`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from qiskit.circuit import Parameter, ParameterVector

from qdensity.execution.unary._layers import Layer, check_gate_list, schedule
from qdensity.execution.unary._plan import Plan, make_plan
from qdensity.execution.unary._tiles import Tilings
from qdensity.validation import Array, Instance, Qubits, SequenceOf, validates

__all__ = ["UnaryCircuit"]


@validates(
    num_qubits=Qubits(1), parameters=SequenceOf(Instance('qiskit.circuit:Parameter'), min_len=0),
    first=Array(ndim=1, dtype='int', min_size=0), second=Array(ndim=1, dtype='int', min_size=0),
    parameter_index=Array(ndim=1, dtype='int', min_size=0), coefficient=Array(ndim=1, min_size=0),
    offset=Array(ndim=1, min_size=0),
)
@dataclass(frozen=True)
class UnaryCircuit:
    """A compiled RBS / FBS circuit: the Givens rotations it applies to unary amplitudes.

    Gate ``g`` rotates the plane ``(first[g], second[g])`` by the angle
    ``coefficient[g] * values[parameter_index[g]] + offset[g]`` (``parameter_index[g] == -1``
    for a fixed angle, which is then ``offset[g]``).

    Attributes
    ----------
    num_qubits : int
        ``n``, the dimension of the unary subspace.
    parameters : tuple of Parameter or ParameterVector
        The circuit's parameters in ``circuit.parameters`` order (the order of ``values``).
    first, second : numpy.ndarray of int, shape (G,)
        Qubits of each rotation in gate-argument order (``first`` is RBS's ``i``).
    parameter_index : numpy.ndarray of int, shape (G,)
        Index into ``parameters``, or ``-1`` for a fixed angle.
    coefficient, offset : numpy.ndarray of float, shape (G,)
        Angle ``= coefficient * value + offset``.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.circuits.ansatze import pyramid
    >>> from qdensity.execution.unary import compile_unary, orthogonal_matrix
    >>> unary = compile_unary(pyramid(4))  # n (n - 1) / 2 = 6 RBS gates, one angle each
    >>> unary.num_qubits, unary.num_gates, unary.num_parameters, len(unary.layers)
    (4, 6, 6, 5)
    >>> O = orthogonal_matrix(unary, np.linspace(0.1, 0.6, 6))
    >>> O.shape, bool(np.allclose(O.T @ O, np.eye(4)))
    ((4, 4), True)
    """

    num_qubits: int
    parameters: Sequence[Parameter]
    first: np.ndarray
    second: np.ndarray
    parameter_index: np.ndarray
    coefficient: np.ndarray
    offset: np.ndarray

    @property
    def num_parameters(self) -> int:
        """Number of circuit parameters ``P``."""
        return len(self.parameters)

    @property
    def num_gates(self) -> int:
        """Number of rotations ``G``."""
        return int(self.first.size)

    @cached_property
    def layers(self) -> list[Layer]:
        """The gates grouped into layers of disjoint rotations (as soon as possible), the unit
        of work of the vectorised kernels; ``len(layers)`` is the circuit's RBS depth."""
        return schedule(self.num_qubits, self.first, self.second, self.parameter_index,
                        self.coefficient)

    @cached_property
    def _plan(self) -> Plan:  # the layers as sparse matrices (kernels for shared angles)
        return make_plan(self.num_qubits, self.layers, self.num_gates)

    @classmethod
    def from_gates(
        cls,
        num_qubits: int,
        pairs,
        parameter_index=None,
        coefficient=None,
        offset=None,
        num_parameters: int | None = None,
        parameters: Sequence[Parameter] | None = None,
    ) -> UnaryCircuit:
        """A unary circuit straight from a gate list, without building a ``QuantumCircuit``.

        Parameters
        ----------
        num_qubits : int
            ``n``.
        pairs : array_like of int, shape (G, 2)
            ``(i, j)`` of each RBS gate in circuit order (an FBS gate on ``[i, ..., j]`` acts
            on unary states as RBS on ``(i, j)``).
        parameter_index : array_like of int, shape (G,), optional
            Parameter of each gate, ``-1`` for a fixed angle; default ``0 .. G - 1`` (one
            parameter per gate, as a ``ParameterVector("theta", G)`` would give).
        coefficient, offset : array_like of float, shape (G,), optional
            Angle ``= coefficient * value + offset``; default 1 and 0.
        num_parameters : int, optional
            ``P``; default ``max(parameter_index) + 1`` (or ``len(parameters)``).
        parameters : sequence of Parameter, optional
            The circuit's ``P`` parameters (a compiled template passes its own: no new
            objects); default a new ``ParameterVector("theta", P)``.

        Returns
        -------
        UnaryCircuit

        Examples
        --------
        >>> c = UnaryCircuit.from_gates(4, [(0, 1), (2, 3), (1, 2)])
        >>> c.num_gates, c.num_parameters, len(c.layers)
        (3, 3, 2)
        >>> from qdensity.execution.unary import forward
        >>> forward(c, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0]).tolist()
        [1.0, 0.0, 0.0, 0.0]
        """
        if parameters is not None:
            parameters = tuple(parameters)
            if num_parameters is None:
                num_parameters = len(parameters)
            elif num_parameters != len(parameters):
                raise ValueError(f"num_parameters = {num_parameters} but {len(parameters)} "
                                 "parameters were given")
        n, first, second, pidx, coef, off, p = check_gate_list(
            num_qubits, pairs, parameter_index, coefficient, offset, num_parameters)
        return cls(n, ParameterVector("theta", p) if parameters is None else parameters,
                   first, second, pidx, coef, off)

    @classmethod
    def _from_checked(cls, num_qubits: int, parameters: tuple, first: np.ndarray,
                      second: np.ndarray, parameter_index: np.ndarray,
                      coefficient: np.ndarray, offset: np.ndarray) -> UnaryCircuit:
        """Private: a unary circuit from arrays its caller already holds in checked form
        (int64 ``first``, ``second``, ``parameter_index`` in ``[-1, P)``, float64 angles,
        ``coefficient`` zero where the angle is fixed), without re-running the declared
        checks: they test each of ``parameters`` (``P`` Python objects) and cost about 15 ms
        a program at ``n = 1024``, thousands of times over a density gradient plan. The
        public constructor and :meth:`from_gates` still check."""
        out = object.__new__(cls)
        for name, value in (("num_qubits", num_qubits), ("parameters", parameters),
                            ("first", first), ("second", second),
                            ("parameter_index", parameter_index),
                            ("coefficient", coefficient), ("offset", offset)):
            object.__setattr__(out, name, value)
        return out

    def angles(self, values: np.ndarray) -> np.ndarray:
        """Gate angles for parameter rows.

        Parameters
        ----------
        values : numpy.ndarray, shape (P,) or (B, P)

        Returns
        -------
        numpy.ndarray, shape (G,) or (G, B)
        """
        values = np.asarray(values, dtype=float)
        idx, scale = self._angle_map
        if values.shape[-1] == 0:
            picked = np.zeros((self.num_gates,) + values.shape[:-1])
        elif values.ndim == 1:
            picked = np.take(values, idx)
        else:
            picked = values[:, idx].T
        if picked.ndim == 2:
            return scale[:, None] * picked + self.offset[:, None]
        picked *= scale  # a fresh array (fancy index or zeros)
        picked += self.offset
        return picked

    @cached_property
    def _gate_rows(self) -> tuple[np.ndarray, np.ndarray]:  # first, second as int64 (kernels)
        return (np.ascontiguousarray(self.first, dtype=np.int64),
                np.ascontiguousarray(self.second, dtype=np.int64))

    @cached_property
    def _gate_params(self) -> tuple[np.ndarray, np.ndarray]:  # parameter index, coefficient
        return (np.ascontiguousarray(self.parameter_index, dtype=np.int64),
                np.ascontiguousarray(self.coefficient, dtype=np.float64))

    @cached_property
    def _gate_offset(self) -> np.ndarray:  # offsets as contiguous float64 (kernels)
        return np.ascontiguousarray(self.offset, dtype=np.float64)

    @cached_property
    def _tilings(self) -> Tilings:  # its gates in cache-tiled orders, when used (._tiles)
        return Tilings()

    @cached_property
    def _angle_map(self) -> tuple[np.ndarray, np.ndarray]:  # parameter of each gate, scale
        free = self.parameter_index >= 0
        return np.where(free, self.parameter_index, 0), self.coefficient * free
