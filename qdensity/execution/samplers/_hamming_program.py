"""A compiled template's program for :class:`~.hamming.HammingWeightSampler`: the unary
engine's circuit (weight 1, RBS / FBS gates) or the subspace's index tables
(:mod:`._hamming_subspace`), built from a :class:`~._hamming_compile.HammingTemplate` or from a
job's precompiled :class:`~qdensity.execution._lazy_jobs.UnaryProgram` (no circuit read).
"""

from __future__ import annotations

from functools import cache, cached_property, lru_cache, partial

import numpy as np

from qdensity.execution.samplers._hamming_compile import HammingTemplate
from qdensity.execution.samplers._hamming_subspace import SubspaceProgram

__all__: list[str] = []


class _Compiled:
    """A template's program: the unary engine's circuit (weight 1, RBS / FBS) or the subspace's
    index tables."""

    def __init__(self, template: HammingTemplate):
        self.template = template
        self.unary = None
        self.program = None
        self.fresh = False  # drop the unary program's cached layers after each use
        self.identity = False  # qubit j measured into clbit j, no other clbit (a program's)
        if template.unary:
            from qdensity.execution.unary import UnaryCircuit

            gates = template.gates
            self.unary = UnaryCircuit.from_gates(
                template.num_qubits,
                [(g.qubits[0], g.qubits[-1]) for g in gates] or np.zeros((0, 2), dtype=int),
                [g.angles[0].index if g.angles[0].kind == "linear" else -1 for g in gates],
                [g.angles[0].coefficient for g in gates],
                [g.angles[0].offset for g in gates],
                parameters=template.parameters,  # the circuit's own: no new Parameters
            )
        else:
            self.program = SubspaceProgram(template)

    @classmethod
    def from_program(cls, program) -> _Compiled:
        """From a job's :class:`~qdensity.execution._lazy_jobs.UnaryProgram`: the template
        :func:`~._hamming_compile.compile_template` would give its measured circuit (every
        qubit ``j`` into clbit ``j``), without its gate list, and the program's rotations."""
        n, unary = program.num_qubits, program.unary
        out = cls.__new__(cls)
        out.template = HammingTemplate(n, (program.occupied,), [], list(range(n)),
                                       tuple(unary.parameters), program.name)
        out.unary, out.program, out.fresh = unary, None, True
        out.identity = True
        return out

    def probabilities(self, values: np.ndarray) -> np.ndarray:
        """(B, D) outcome probabilities for rows (B, P)."""
        return self.probabilities_function()(values)

    def probabilities_function(self):
        """:meth:`probabilities` as a function that holds the program alone (not the
        template's gate list): what a deferred drawing keeps."""
        if self.unary is not None:
            x = _basis_state(self.template.num_qubits, self.template.occupied[0])
            return partial(_unary_probabilities, self.unary, x, fresh=self.fresh)
        assert self.program is not None  # the subspace path
        return self.program.probabilities

    def outcome_qubits(self) -> np.ndarray:
        """(D, k) the qubits set in each outcome."""
        if self.unary is not None:
            return _qubit_column(self.template.num_qubits)
        assert self.program is not None  # the subspace path
        return self.program.space.states


@lru_cache(maxsize=64)
def _basis_state(n: int, occupied: int) -> np.ndarray:
    """``e_occupied`` of length ``n``, read-only: one array for every program of that width
    and input (a deferred drawing holds it until read: 2,046 of 8 KB at ``n = 1024``)."""
    x = np.zeros(n)
    x[occupied] = 1.0
    x.flags.writeable = False
    return x


@lru_cache(maxsize=64)
def _qubit_column(n: int) -> np.ndarray:
    """``arange(n)[:, None]`` read-only: the unary outcomes' qubits, one array per width."""
    out = np.arange(n)[:, None]
    out.flags.writeable = False
    return out


@lru_cache(maxsize=64)
def identity_clbits(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A program's measured clbits (every qubit ``j`` into clbit ``j``): the clbits read
    (``arange(n)``) and :func:`~._hamming_bits.clbits_of_qubits`' table (``arange(n)[:, None]``),
    read-only, one pair per width."""
    cols = np.arange(n, dtype=np.int64)
    table = cols[:, None].copy()
    cols.flags.writeable = False
    table.flags.writeable = False
    return cols, table


def _unary_probabilities(unary, x: np.ndarray, values: np.ndarray, *, fresh: bool = False
                         ) -> np.ndarray:
    """(B, n) outcome probabilities of a weight-1 template: the unary engine on ``x``
    (``fresh``: the layers ``unary`` caches on first use are dropped afterwards, so a program
    that a deferred drawing holds until read does not keep them: at n = 1024 about 0.5 MB a
    template)."""
    from qdensity.execution.unary import forward

    if unary.num_gates == 0:
        return np.broadcast_to(x**2, (values.shape[0], x.size)).copy()
    x = np.broadcast_to(x, (values.shape[0], x.size))
    try:
        return forward(unary, x, values) ** 2
    finally:
        if fresh:  # its cached properties (functools.cached_property keeps them in __dict__)
            for name in cached_names():
                vars(unary).pop(name, None)


@cache
def cached_names() -> tuple[str, ...]:
    """UnaryCircuit's cached properties (its layers, their kernels' plan and arrays, the angle
    map), read off the class so that a new one is dropped too."""
    from qdensity.execution.unary import UnaryCircuit

    return tuple(k for k, v in vars(UnaryCircuit).items() if isinstance(v, cached_property))
