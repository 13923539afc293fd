"""The named circuits of ``qdensity build`` and ``qdensity transpile``: name -> builder.

Every builder takes the number of (data) qubits; data vectors and bound parameter values are
seeded, so a name and a size always give the same circuit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from qiskit import QuantumCircuit

from qdensity.validation import Instance, Qubits, Seed, validates

__all__ = ["BUILDERS", "build_circuit"]


def _vector(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=n)


def _loader(layout: str) -> Callable[[int], QuantumCircuit]:
    def make(n: int) -> QuantumCircuit:
        from qdensity.circuits.loaders import unary_loader

        return unary_loader(_vector(n), layout=layout)
    return make


def _ansatz(name: str) -> Callable[[int], QuantumCircuit]:
    def make(n: int) -> QuantumCircuit:
        from qdensity.circuits import ansatze

        if name == "hardware_efficient":
            return ansatze.hardware_efficient(n, 2)
        if name == "equivariant_xx":
            return ansatze.equivariant_commuting(n, "X")
        if name == "equivariant_yy":
            return ansatze.equivariant_commuting(n, "Y")
        if name == "equivariant_noncommuting":
            return ansatze.equivariant_noncommuting(n, 2)
        if name == "reuploading":
            return ansatze.reuploading(n)
        return getattr(ansatze, name)(n)
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


#: Named circuit builders for ``build`` and ``transpile``: name -> f(num_qubits).
BUILDERS: dict[str, Callable[[int], QuantumCircuit]] = {
    "loader_parallel": _loader("parallel"),
    "loader_diagonal": _loader("diagonal"),
    "loader_semi_diagonal": _loader("semi_diagonal"),
    "pyramid": _ansatz("pyramid"),
    "x_circuit": _ansatz("x_circuit"),
    "butterfly": _ansatz("butterfly"),
    "round_robin": _ansatz("round_robin"),
    "hardware_efficient": _ansatz("hardware_efficient"),
    "equivariant_xx": _ansatz("equivariant_xx"),
    "equivariant_yy": _ansatz("equivariant_yy"),
    "equivariant_noncommuting": _ansatz("equivariant_noncommuting"),
    "qcnn": _ansatz("qcnn"),
    "reuploading": _ansatz("reuploading"),
    "deterministic": _density("deterministic"),
    "lcu": _density("lcu"),
    "commuting_gradient": _gradient,
    "tomography_0": _tomography(0),
    "tomography_1": _tomography(1),
    "tomography_2": _tomography(2),
}


#: Smallest size each builder accepts (2 unless listed; butterfly also needs a power of two).
MIN_SIZE = {"reuploading": 1, "equivariant_xx": 3, "equivariant_yy": 3}


def size_range(name: str, largest: int) -> str:
    """The sizes ``name`` accepts up to ``largest``, in words (for the CLI's messages)."""
    low = MIN_SIZE.get(name, 2)
    extra = " and a power of two" if name == "butterfly" else ""
    return f"an int in [{low}, {largest}]{extra} for {name}"


def check_size(name: str, size: int, largest: int) -> None:
    """Refuse a ``--size`` that ``name`` cannot build, stating its real range."""
    low = MIN_SIZE.get(name, 2)
    if name in BUILDERS and not (low <= size <= largest and (name != "butterfly"
                                                             or size & (size - 1) == 0)):
        raise ValueError(f"--size must be {size_range(name, largest)}, got {size}")


@validates(name=Instance(str), num_qubits=Qubits(1), bind_seed=Seed())
def build_circuit(name: str, num_qubits: int, *, bind_seed: int | None = 0) -> QuantumCircuit:
    """Build a named circuit (see :data:`BUILDERS`), its parameters bound with seeded values.

    The circuit is named ``"{name}_{num_qubits}"`` (stable across runs).

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones).
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
