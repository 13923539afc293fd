"""The catalogue of reference circuits: every builder at a small size, as OpenQASM 2.

Each entry of :data:`REFERENCE_BUILDERS` builds one circuit of the toolkit (loaders, ansätze,
density-QNN preparations of Fig. 1 and Fig. 13b, a commuting-generator gradient circuit of
Methods eq. 9, the three l-infinity tomography circuits of Supp. F) at a small reference size
with *fixed* parameter values, so that the circuits can be read by any OpenQASM 2 tool, diffed
between versions, and run on hardware without this package.

Parameter values are drawn from ``numpy.random.default_rng(seed).uniform(-pi, pi)`` with a
seed derived from the circuit's name (:func:`reference_seed`), in ``circuit.parameters`` order;
data vectors of the loaders are fixed signed vectors with a zero.

The exported text is :func:`qiskit.qasm2.dumps` of the circuit unrolled into gates of
``qelib1.inc`` (:data:`QASM2_BASIS`) at optimisation level 0: the gate sequence of the
builder, with every RBS, FBS, Pauli evolution or controlled block replaced by its definition.
Custom gates are not emitted as ``gate`` definitions, because ``qasm2.dumps`` names the second
and later instances of a custom gate after their memory address (not reproducible) and bakes
the first instance's angle into the definition. The global phase is dropped (OpenQASM 2 has
none), so a file reloads to a circuit equal to the builder's up to a global phase; final
measurements are kept where the builder has them.

Every reference circuit is also exported as OpenQASM 3 (:func:`reference_qasm3`, files
``<name>.qasm3``) with its parameters kept *symbolic*, so that a provider binds them: the
trainable angles of the ansätze (``θ``, ...) and the data angles of the unary loaders (``x``,
:func:`qdensity.circuits.loaders.unary_loader_template`) are ``input float[64]`` declarations, in
the
order of the circuit's parameters. The catalogue is the same: :func:`bind_reference` binds
nothing and :func:`_data_loader` builds template loaders while :func:`symbolic_circuit` builds.
The matrix loader, ``Load(sqrt(alpha))``, the mixtures alpha and the loader of the gradient
circuit (whose diagonalising layer is built for fixed data) keep their fixed values. The circuit
is unrolled into the gates of ``stdgates.inc`` (:data:`QASM3_BASIS`) at optimisation level 0.

This module holds the catalogue (:data:`REFERENCE_BUILDERS`, their descriptions, seeds and
parameter binding) and the exported form of one circuit (:func:`reference_circuit`,
:func:`reference_qasm`). Writing and checking the ``circuits/`` directory, and the command
line, live in :mod:`qdensity.cli.export`: regenerate the directory with ``qdensity export`` or
``python -m qdensity.cli.export [DIR]``; :func:`qdensity.cli.export.check_circuits` lists the files
that are missing or out of date.

Examples
--------
>>> qc = REFERENCE_BUILDERS["pyramid_4"]()
>>> qc.num_qubits, qc.num_parameters
(4, 0)
>>> text = reference_qasm("pyramid_4")
>>> text.splitlines()[0]
'OPENQASM 2.0;'
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import zlib
from collections.abc import Callable, Iterable
from functools import cache

import numpy as np
from qiskit import qasm2, qasm3, transpile
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    butterfly,
    equivariant_commuting,
    equivariant_noncommuting,
    hardware_efficient,
    pairs_circuit,
    pyramid,
    qcnn,
    reuploading,
    round_robin,
    round_robin_pairs,
    x_circuit,
)
from qdensity.circuits.loaders import (
    distribution_loader,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)
from qdensity.circuits.preparation import deterministic_circuit, hw_generative_circuit, lcu_circuit
from qdensity.circuits.tomography import tomography_circuits
from qdensity.gradients.commuting import commuting_gradient
from qdensity.models.decompositions import by_moments

__all__ = ["QASM2_BASIS", "REFERENCE_BUILDERS", "REFERENCE_DESCRIPTIONS", "reference_seed",
           "bind_reference", "reference_circuit", "reference_qasm", "QASM3_BASIS",
           "symbolic_circuit", "reference_qasm3"]

#: Gates of the original ``qelib1.inc`` (the file ``qiskit.qasm2.loads`` and other OpenQASM 2
#: readers include) that exported circuits may contain; everything else is unrolled. Newer
#: Qiskit additions such as ``p``, ``sx``, ``swap``, ``cry`` or ``rxx`` are not in that file.
QASM2_BASIS: tuple[str, ...] = (
    "u1", "u2", "u3", "x", "y", "z", "h", "s", "sdg", "t", "tdg", "rx", "ry", "rz",
    "cx", "cy", "cz", "ch", "crz", "cu1", "cu3", "ccx",
)

#: Gates of OpenQASM 3's ``stdgates.inc`` that the symbolic exports may contain.
QASM3_BASIS: tuple[str, ...] = (
    "x", "y", "z", "h", "s", "sdg", "t", "tdg", "sx", "rx", "ry", "rz", "p",
    "cx", "cy", "cz", "cp", "crx", "cry", "crz", "ch", "swap", "ccx",
)

# Whether the builders are building the symbolic (OpenQASM 3) form.
_SYMBOLIC: contextvars.ContextVar[bool] = contextvars.ContextVar("symbolic", default=False)

# Reference data: fixed signed vectors with a zero (loaders) and a distribution.
_VECTOR_5 = (0.8, -0.3, 0.0, 0.5, -1.1)
_VECTOR_4 = (0.6, -0.2, 0.0, 0.9)
_MATRIX_2X3 = ((1.0, -2.0, 0.5), (0.0, 0.7, -1.2))
_ALPHA_4 = (0.4, 0.3, 0.2, 0.1)
_ALPHA_3 = (0.5, 0.3, 0.2)
_ALPHA_2 = (0.6, 0.4)

REFERENCE_BUILDERS: dict[str, Callable[[], QuantumCircuit]] = {}
REFERENCE_DESCRIPTIONS: dict[str, str] = {}


def reference_seed(name: str) -> int:
    """Seed of a reference circuit's parameter values: the CRC-32 of its name.

    Parameters
    ----------
    name : str
        Reference name, e.g. ``"pyramid_4"``.

    Returns
    -------
    int
        In ``[0, 2**32)``; the same on every platform and Python version (unlike ``hash``).

    Raises
    ------
    TypeError
        If ``name`` is not a str.
    ValueError
        If ``name`` is empty.

    Examples
    --------
    >>> reference_seed("pyramid_4") == reference_seed("pyramid_4")
    True
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__} {name!r}")
    if not name:
        raise ValueError("name must be a non-empty str, got ''")
    return zlib.crc32(name.encode("utf-8"))


def bind_reference(circuit: QuantumCircuit, name: str) -> QuantumCircuit:
    """Bind every free parameter of ``circuit`` to fixed values seeded by ``name``.

    Parameters
    ----------
    circuit : QuantumCircuit
        ``P`` free parameters (``P = 0`` returns a copy).
    name : str
        Seed source (:func:`reference_seed`).

    Returns
    -------
    QuantumCircuit
        ``circuit`` with ``circuit.parameters[i]`` bound to
        ``default_rng(reference_seed(name)).uniform(-pi, pi, P)[i]``.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import pyramid
    >>> bind_reference(pyramid(4), "pyramid_4") == bind_reference(pyramid(4), "pyramid_4")
    True
    """
    rng = np.random.default_rng(reference_seed(name))
    if _SYMBOLIC.get():  # building the OpenQASM 3 form: parameters stay free
        return circuit.copy()
    values = rng.uniform(-math.pi, math.pi, circuit.num_parameters)
    return circuit.assign_parameters(values.tolist())


def _reference(name: str) -> Callable[[Callable[[], QuantumCircuit]], Callable[[], QuantumCircuit]]:
    """Register a builder under ``name``; its docstring's first line is its description."""

    def register(func: Callable[[], QuantumCircuit]) -> Callable[[], QuantumCircuit]:
        if name in REFERENCE_BUILDERS:
            raise ValueError(f"duplicate reference circuit name {name!r}")
        REFERENCE_BUILDERS[name] = func
        REFERENCE_DESCRIPTIONS[name] = (func.__doc__ or name).strip().splitlines()[0]
        return func

    return register


def _data_loader(vector, layout: str = "parallel") -> QuantumCircuit:
    """A unary loader of ``vector``; in the symbolic form, the template with data angles ``x``."""
    if _SYMBOLIC.get():
        return unary_loader_template(len(vector), layout)
    return unary_loader(vector, layout)


@contextlib.contextmanager
def _symbolic():
    token = _SYMBOLIC.set(True)
    try:
        yield
    finally:
        _SYMBOLIC.reset(token)


# --------------------------------------------------------------------------------------------
# The reference circuits
# --------------------------------------------------------------------------------------------


@_reference("loader_parallel_5")
def _loader_parallel_5() -> QuantumCircuit:
    """Unary loader, parallel tree layout (RBS depth 3), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return _data_loader(_VECTOR_5, "parallel")


@_reference("loader_diagonal_5")
def _loader_diagonal_5() -> QuantumCircuit:
    """Unary loader, diagonal chain layout (RBS depth 4), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return _data_loader(_VECTOR_5, "diagonal")


@_reference("loader_semi_diagonal_5")
def _loader_semi_diagonal_5() -> QuantumCircuit:
    """Unary loader, semi-diagonal layout (RBS depth 3), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return _data_loader(_VECTOR_5, "semi_diagonal")


@_reference("matrix_loader_2x3")
def _matrix_loader_2x3() -> QuantumCircuit:
    """Matrix loader of X = [[1, -2, 0.5], [0, 0.7, -1.2]] (Supp. I.2), registers row, col."""
    return matrix_loader(_MATRIX_2X3, "parallel")


@_reference("load_sqrt_alpha_4")
def _load_sqrt_alpha_4() -> QuantumCircuit:
    """Load(sqrt(alpha)) of Fig. 1 for alpha = (0.4, 0.3, 0.2, 0.1)."""
    return distribution_loader(_ALPHA_4)


@_reference("pyramid_4")
def _pyramid_4() -> QuantumCircuit:
    """Pyramid RBS ansatz (Fig. 9a), 6 RBS gates."""
    return bind_reference(pyramid(4), "pyramid_4")


@_reference("x_circuit_4")
def _x_circuit_4() -> QuantumCircuit:
    """X RBS ansatz (Fig. 9b), 5 RBS gates."""
    return bind_reference(x_circuit(4), "x_circuit_4")


@_reference("butterfly_4")
def _butterfly_4() -> QuantumCircuit:
    """Butterfly RBS ansatz (Fig. 9c), 4 RBS gates in 2 layers."""
    return bind_reference(butterfly(4), "butterfly_4")


@_reference("round_robin_4")
def _round_robin_4() -> QuantumCircuit:
    """Round-robin RBS ansatz, 6 RBS gates in 3 rounds."""
    return bind_reference(round_robin(4), "round_robin_4")


@_reference("round_robin_fbs_4")
def _round_robin_fbs_4() -> QuantumCircuit:
    """Round-robin ansatz with FBS gates (compound circuit, Supp. E.2)."""
    return bind_reference(round_robin(4, gate="fbs"), "round_robin_fbs_4")


@_reference("hardware_efficient_3x2")
def _hardware_efficient_3x2() -> QuantumCircuit:
    """Hardware-efficient ansatz (Fig. 3): 2 layers of RY rotations and CNOT ladders."""
    return bind_reference(hardware_efficient(3, 2), "hardware_efficient_3x2")


@_reference("equivariant_xx_4")
def _equivariant_xx_4() -> QuantumCircuit:
    """Commuting-generator translation-equivariant XX model (Fig. 4a), weights 1..3."""
    return bind_reference(equivariant_commuting(4, "X", max_weight=3), "equivariant_xx_4")


@_reference("equivariant_yy_4")
def _equivariant_yy_4() -> QuantumCircuit:
    """Commuting-generator translation-equivariant YY model (Fig. 4a), weights 1..3."""
    return bind_reference(equivariant_commuting(4, "Y", max_weight=3), "equivariant_yy_4")


@_reference("equivariant_noncommuting_4")
def _equivariant_noncommuting_4() -> QuantumCircuit:
    """Non-commuting translation-equivariant model (Fig. 4c), 2 layers."""
    return bind_reference(equivariant_noncommuting(4, 2), "equivariant_noncommuting_4")


@_reference("qcnn_4")
def _qcnn_4() -> QuantumCircuit:
    """QCNN of convolution and pooling layers down to one readout qubit (Methods)."""
    return bind_reference(qcnn(4), "qcnn_4")


@_reference("reuploading_3")
def _reuploading_3() -> QuantumCircuit:
    """Single-qubit data re-uploading circuit, 3 uploads (Methods eq. 10-11)."""
    return bind_reference(reuploading(3), "reuploading_3")


def _round_robin_layers() -> list[QuantumCircuit]:
    """Sub-unitaries of round_robin(4) cut by moments (one round each, sharing its parameters)."""
    return by_moments(round_robin(4)).sub_unitaries


@_reference("deterministic_k3")
def _deterministic_k3() -> QuantumCircuit:
    """Deterministic density QNN (Fig. 1b): K=3 round-robin rounds, alpha=(0.5, 0.3, 0.2)."""
    qc = deterministic_circuit(_round_robin_layers(), _ALPHA_3, _data_loader(_VECTOR_4))
    return bind_reference(qc, "deterministic_k3")


@_reference("lcu_k3")
def _lcu_k3() -> QuantumCircuit:
    """LCU density QNN (Fig. 1a): K=3 round-robin rounds, post-select mix = 000."""
    qc = lcu_circuit(_round_robin_layers(), _ALPHA_3, _data_loader(_VECTOR_4))
    return bind_reference(qc, "lcu_k3")


@_reference("hw_generative_k2")
def _hw_generative_k2() -> QuantumCircuit:
    """HW-preserving generative density QNN (Fig. 13b): K=2 halves of round_robin(4)."""
    subs = by_moments(round_robin(4), depth=2).sub_unitaries
    return bind_reference(hw_generative_circuit(subs, _ALPHA_2), "hw_generative_k2")


@_reference("commuting_gradient_round_robin_layer_4")
def _commuting_gradient_round_robin_layer_4() -> QuantumCircuit:
    """Gradient circuit (Methods eq. 9): loader, one round-robin layer, RBS(pi/4) diagonaliser."""
    layer = pairs_circuit(4, [round_robin_pairs(4)[0]], name="round_robin_layer_4")
    circuit = unary_loader(_VECTOR_4).compose(layer)
    observable = SparsePauliOp.from_sparse_list([("Z", [q], 1.0) for q in range(4)], 4)
    gradient = commuting_gradient(circuit, observable)
    return bind_reference(gradient.circuits[0], "commuting_gradient_round_robin_layer_4")


def _tomography_builder(index: int) -> Callable[[], QuantumCircuit]:
    basis = ("computational basis", "RBS(pi/4) on (0,1),(2,3)", "RBS(pi/4) on (1,2)")[index]

    def build() -> QuantumCircuit:
        state = _data_loader(_VECTOR_4).compose(pyramid(4))
        state = bind_reference(state, "tomography_4")  # one state for all three circuits
        return tomography_circuits(state)[index]

    build.__doc__ = f"Unary l-infinity tomography (Supp. F), circuit {index}: {basis}, measured."
    return build


for _index in range(3):
    _reference(f"tomography_{_index}_4")(_tomography_builder(_index))
del _index


# --------------------------------------------------------------------------------------------
# The exported form
# --------------------------------------------------------------------------------------------


def _check_name(name) -> str:
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__} {name!r}")
    if name not in REFERENCE_BUILDERS:
        raise ValueError(
            f"name {name!r} is not a reference circuit; known: {sorted(REFERENCE_BUILDERS)}"
        )
    return name


def _check_names(names) -> list[str]:
    if names is None:
        return list(REFERENCE_BUILDERS)
    if isinstance(names, str) or not isinstance(names, Iterable):
        raise TypeError(f"names must be None or an iterable of str, got {names!r}")
    return [_check_name(n) for n in names]


def reference_circuit(name: str) -> QuantumCircuit:
    """The exported form of a reference circuit: unrolled into :data:`QASM2_BASIS`.

    Parameters
    ----------
    name : str
        A key of :data:`REFERENCE_BUILDERS`.

    Returns
    -------
    QuantumCircuit
        The builder's circuit (same registers, measurements kept), every gate outside
        ``qelib1.inc`` replaced by its definition; equal to the builder's up to global phase.

    Examples
    --------
    >>> sorted(reference_circuit("pyramid_4").count_ops())  # RBS unrolled into qelib1.inc gates
    ['cz', 'h', 'ry']
    """
    circuit = REFERENCE_BUILDERS[_check_name(name)]()
    return transpile(circuit, basis_gates=list(QASM2_BASIS), optimization_level=0)


def reference_qasm(name: str) -> str:
    """OpenQASM 2 text of a reference circuit, as written to ``<name>.qasm``.

    Parameters
    ----------
    name : str
        A key of :data:`REFERENCE_BUILDERS`.

    Returns
    -------
    str
        ``qasm2.dumps`` of :func:`reference_circuit`, with a comment line naming and describing
        the circuit after the version line, ending in a newline.

    Examples
    --------
    >>> reference_qasm("pyramid_4").splitlines()[1]
    '// pyramid_4: Pyramid RBS ansatz (Fig. 9a), 6 RBS gates.'
    """
    return _exported(_check_name(name))[0]


@cache
def _exported(name: str) -> tuple[str, int, int, int]:
    """(text, qubits, two-qubit gates, depth) of the exported circuit; strings and ints only,
    so the cache cannot be mutated by a caller."""
    circuit = reference_circuit(name)
    header, rest = qasm2.dumps(circuit).split("\n", 1)
    text = f"{header}\n// {name}: {REFERENCE_DESCRIPTIONS[name]}\n{rest}\n"
    two_qubit = sum(
        1 for inst in circuit.data
        if len(inst.qubits) == 2 and inst.operation.name not in ("barrier", "measure")
    )
    return text, circuit.num_qubits, two_qubit, circuit.depth()


def symbolic_circuit(name: str) -> QuantumCircuit:
    """The OpenQASM 3 form of a reference circuit: parameters free, unrolled into stdgates.

    Parameters
    ----------
    name : str
        A key of :data:`REFERENCE_BUILDERS`.

    Returns
    -------
    QuantumCircuit
        The builder's circuit with its trainable and loader-data parameters free (same
        ``parameters`` order), every gate outside :data:`QASM3_BASIS` replaced by its
        definition; for any values it equals the builder's circuit up to global phase.

    Examples
    --------
    >>> [p.name for p in symbolic_circuit("pyramid_4").parameters][:2]
    ['θ[0]', 'θ[1]']
    """
    with _symbolic():
        circuit = REFERENCE_BUILDERS[_check_name(name)]()
    return transpile(circuit, basis_gates=list(QASM3_BASIS), optimization_level=0)


def reference_qasm3(name: str) -> str:
    """OpenQASM 3 text of a reference circuit with symbolic parameters (``<name>.qasm3``).

    Parameters
    ----------
    name : str
        A key of :data:`REFERENCE_BUILDERS`.

    Returns
    -------
    str
        ``qasm3.dumps`` of :func:`symbolic_circuit`, with a comment line naming and describing
        the circuit after the version line; one ``input float[64]`` per free parameter, in
        ``parameters`` order. Reload with ``qiskit.qasm3.loads`` (``qiskit-qasm3-import``).

    Examples
    --------
    >>> reference_qasm3("pyramid_4").count("input float[64]")  # one per RBS angle
    6
    """
    return _exported3(_check_name(name))[0]


@cache
def _exported3(name: str) -> tuple[str, int]:
    """(text, number of symbolic parameters) of the OpenQASM 3 export (immutable, cached)."""
    circuit = symbolic_circuit(name)
    header, rest = qasm3.dumps(circuit).split("\n", 1)
    return f"{header}\n// {name}: {REFERENCE_DESCRIPTIONS[name]}\n{rest}\n", circuit.num_parameters
