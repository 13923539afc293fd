"""The named circuits of ``qdensity build`` and ``qdensity transpile``: name -> builder.

Every builder takes the number of (data) qubits; data vectors and bound parameter values are
seeded, so a name and a size always give the same circuit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

import numpy as np
from qiskit import QuantumCircuit

from qdensity.circuits.ansatze.registry import FAMILIES, AnsatzFamily
from qdensity.validation import Instance, Qubits, Seed, validates

__all__ = ["BUILDERS", "build_circuit"]


def _vector(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=n)


def _loader(layout: str) -> Callable[[int], QuantumCircuit]:
    def make(n: int) -> QuantumCircuit:
        from qdensity.circuits.loaders import unary_loader

        return unary_loader(_vector(n), layout=layout)
    return make


def _density(kind: str) -> Callable[[int], QuantumCircuit]:
    def make(n: int) -> QuantumCircuit:
        from qdensity.circuits.ansatze import round_robin
        from qdensity.circuits.loaders import unary_loader
        from qdensity.circuits.preparation import deterministic_circuit, lcu_circuit
        from qdensity.models.decompositions import by_moments

        subs = by_moments(round_robin(n)).sub_unitaries
        alpha = np.full(len(subs), 1.0 / len(subs))
        build = deterministic_circuit if kind == "deterministic" else lcu_circuit
        return build(subs, alpha, loader=unary_loader(_vector(n)))
    return make


def _gradient(n: int) -> QuantumCircuit:
    from qiskit.quantum_info import SparsePauliOp

    from qdensity.circuits.ansatze import round_robin
    from qdensity.circuits.loaders import unary_loader
    from qdensity.gradients import commuting_gradient
    from qdensity.models.decompositions import by_moments

    layer = by_moments(round_robin(n)).sub_unitaries[0]
    circ = unary_loader(_vector(n)).compose(layer)
    obs = SparsePauliOp.from_sparse_list([("Z", [q], 1.0) for q in range(n)], n)
    return commuting_gradient(circ, obs).circuits[0]


def _tomography(index: int) -> Callable[[int], QuantumCircuit]:
    def make(n: int) -> QuantumCircuit:
        from qdensity.circuits.ansatze import pyramid
        from qdensity.circuits.loaders import unary_loader
        from qdensity.circuits.tomography import tomography_circuits

        return tomography_circuits(unary_loader(_vector(n)).compose(pyramid(n)))[index]
    return make


class _Builders(Mapping):
    """Name -> f(num_qubits): the loaders, every ansatz family of the registry
    (:data:`~qdensity.circuits.ansatze.registry.FAMILIES`, read at each use, under its
    command-line name), then the density, gradient and tomography circuits."""

    def __init__(self, before: dict, after: dict):
        self._before, self._after = before, after

    def _families(self) -> dict[str, Callable[[int], QuantumCircuit]]:
        return {f.command_name: f.builder for f in FAMILIES.values()}

    def _all(self) -> dict[str, Callable[[int], QuantumCircuit]]:
        return {**self._before, **self._families(), **self._after}

    def __getitem__(self, name: str) -> Callable[[int], QuantumCircuit]:
        return self._all()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())

    def __repr__(self) -> str:
        return f"BUILDERS({', '.join(self)})"


#: Named circuit builders for ``build`` and ``transpile``: name -> f(num_qubits).
BUILDERS: Mapping[str, Callable[[int], QuantumCircuit]] = _Builders(
    {"loader_parallel": _loader("parallel"),
     "loader_diagonal": _loader("diagonal"),
     "loader_semi_diagonal": _loader("semi_diagonal")},
    {"deterministic": _density("deterministic"),
     "lcu": _density("lcu"),
     "commuting_gradient": _gradient,
     "tomography_0": _tomography(0),
     "tomography_1": _tomography(1),
     "tomography_2": _tomography(2)},
)


def _family(name: str) -> AnsatzFamily | None:
    return next((f for f in FAMILIES.values() if f.command_name == name), None)


def size_range(name: str, largest: int) -> str:
    """The sizes ``name`` accepts up to ``largest``, in words (for the CLI's messages)."""
    family = _family(name)
    low = family.min_qubits if family is not None else 2
    extra = " and a power of two" if family is not None and family.power_of_two else ""
    return f"an int in [{low}, {largest}]{extra} for {name}"


def check_size(name: str, size: int, largest: int) -> None:
    """Refuse a ``--size`` that ``name`` cannot build, stating its real range."""
    family = _family(name)
    if name not in BUILDERS:
        return
    ok = family.accepts(size) if family is not None else size >= 2
    if not (ok and size <= largest):
        raise ValueError(f"--size must be {size_range(name, largest)}, got {size}")


@validates(name=Instance(str), num_qubits=Qubits(1), bind_seed=Seed())
def build_circuit(name: str, num_qubits: int, *, bind_seed: int | None = 0) -> QuantumCircuit:
    """Build a named circuit (see :data:`BUILDERS`), its parameters bound with seeded values.

    The circuit is named ``"{name}_{num_qubits}"`` (stable across runs).

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones).

    Examples
    --------
    >>> qc = build_circuit("pyramid", 4)
    >>> qc.num_qubits, qc.num_parameters, dict(qc.count_ops())  # parameters bound
    (4, 0, {'rbs': 6})
    """
    if name not in BUILDERS:
        raise ValueError(f"unknown builder {name!r} (argument name); known builders: "
                         f"{', '.join(BUILDERS)}")
    qc = BUILDERS[name](num_qubits)
    if bind_seed is not None and qc.num_parameters:
        qc = qc.assign_parameters(
            np.random.default_rng(bind_seed).uniform(-np.pi, np.pi, qc.num_parameters))
    # Qiskit's copies (assign_parameters, compose) append an instance counter ("-48") that
    # changes from run to run; the name is the builder's and the size
    qc.name = f"{name}_{num_qubits}"
    return qc
