"""Exported reference circuits: every builder at a small size, as OpenQASM 2 (``circuits/``).

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

Regenerate the directory with ``qdensity export`` or ``python -m qdensity.export [DIR]``;
:func:`check_circuits` lists the files that are missing or out of date.

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

import argparse
import math
import re
import zlib
from collections.abc import Callable, Iterable, Sequence
from functools import cache
from pathlib import Path

import numpy as np
from qiskit import qasm2, transpile
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
from qdensity.circuits.loaders import distribution_loader, matrix_loader, unary_loader
from qdensity.circuits.preparation import deterministic_circuit, hw_generative_circuit, lcu_circuit
from qdensity.circuits.tomography import tomography_circuits
from qdensity.gradients.commuting import commuting_gradient
from qdensity.models.decompositions import by_moments

__all__ = [
    "QASM2_BASIS",
    "INDEX_NAME",
    "REFERENCE_BUILDERS",
    "REFERENCE_DESCRIPTIONS",
    "reference_seed",
    "bind_reference",
    "reference_circuit",
    "reference_qasm",
    "export_circuits",
    "check_circuits",
    "index_markdown",
    "main",
]

#: Gates of the original ``qelib1.inc`` (the file ``qiskit.qasm2.loads`` and other OpenQASM 2
#: readers include) that exported circuits may contain; everything else is unrolled. Newer
#: Qiskit additions such as ``p``, ``sx``, ``swap``, ``cry`` or ``rxx`` are not in that file.
QASM2_BASIS: tuple[str, ...] = (
    "u1", "u2", "u3", "x", "y", "z", "h", "s", "sdg", "t", "tdg", "rx", "ry", "rz",
    "cx", "cy", "cz", "ch", "crz", "cu1", "cu3", "ccx",
)

#: Name of the index written next to the ``.qasm`` files.
INDEX_NAME = "README.md"

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
    """
    rng = np.random.default_rng(reference_seed(name))
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


# --------------------------------------------------------------------------------------------
# The reference circuits
# --------------------------------------------------------------------------------------------


@_reference("loader_parallel_5")
def _loader_parallel_5() -> QuantumCircuit:
    """Unary loader, parallel tree layout (RBS depth 3), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return unary_loader(_VECTOR_5, "parallel")


@_reference("loader_diagonal_5")
def _loader_diagonal_5() -> QuantumCircuit:
    """Unary loader, diagonal chain layout (RBS depth 4), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return unary_loader(_VECTOR_5, "diagonal")


@_reference("loader_semi_diagonal_5")
def _loader_semi_diagonal_5() -> QuantumCircuit:
    """Unary loader, semi-diagonal layout (RBS depth 3), x = (0.8, -0.3, 0, 0.5, -1.1)."""
    return unary_loader(_VECTOR_5, "semi_diagonal")


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
    qc = deterministic_circuit(_round_robin_layers(), _ALPHA_3, unary_loader(_VECTOR_4))
    return bind_reference(qc, "deterministic_k3")


@_reference("lcu_k3")
def _lcu_k3() -> QuantumCircuit:
    """LCU density QNN (Fig. 1a): K=3 round-robin rounds, post-select mix = 000."""
    qc = lcu_circuit(_round_robin_layers(), _ALPHA_3, unary_loader(_VECTOR_4))
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
        state = unary_loader(_VECTOR_4).compose(pyramid(4))
        state = bind_reference(state, "tomography_4")  # one state for all three circuits
        return tomography_circuits(state)[index]

    build.__doc__ = f"Unary l-infinity tomography (Supp. F), circuit {index}: {basis}, measured."
    return build


for _index in range(3):
    _reference(f"tomography_{_index}_4")(_tomography_builder(_index))
del _index


# --------------------------------------------------------------------------------------------
# Export
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


def index_markdown(names: Sequence[str] | None = None) -> str:
    """The ``README.md`` index of the exported circuits.

    Parameters
    ----------
    names : sequence of str, optional
        Reference names, default all of :data:`REFERENCE_BUILDERS`.

    Returns
    -------
    str
        Markdown: a table of file, qubits, two-qubit gates and depth of the exported circuit,
        and a one-line description, followed by how to regenerate and check the files.
    """
    rows = []
    for name in _check_names(names):
        _, qubits, two_qubit, depth = _exported(name)
        rows.append(
            f"| [`{name}.qasm`]({name}.qasm) | {qubits} | {two_qubit} | {depth} | "
            f"{REFERENCE_DESCRIPTIONS[name]} |"
        )
    lines = [
        "# Reference circuits",
        "",
        "Every circuit builder of `qdensity` at a small reference size, with fixed parameter",
        "values, exported as OpenQASM 2 (`include \"qelib1.inc\"`; RBS, FBS and the other",
        "custom gates are unrolled into standard gates). Parameter values are",
        "`numpy.random.default_rng(crc32(name)).uniform(-pi, pi)` in `circuit.parameters`",
        "order; loader inputs are fixed signed vectors with a zero. Files reload with",
        "`qiskit.qasm2.load` to a circuit equal to the builder's up to a global phase.",
        "Two-qubit gates and depth are those of the exported circuit (measurements count",
        "towards depth, not towards two-qubit gates).",
        "",
        "| file | qubits | two-qubit gates | depth | description |",
        "|---|---:|---:|---:|---|",
        *rows,
        "",
        "## Regenerate",
        "",
        "These files are generated; do not edit them by hand. Regenerate with",
        "",
        "```",
        "qdensity export",
        "```",
        "",
        "or `python -m qdensity.export [DIRECTORY]` (default `./circuits`). The test suite",
        "checks that the files are current (`qdensity.export.check_circuits`) and that each",
        "reloads to its builder's operator.",
        "",
    ]
    return "\n".join(lines)


def export_circuits(directory: str | Path, names: Sequence[str] | None = None) -> list[Path]:
    """Write ``<name>.qasm`` for each reference circuit and the ``README.md`` index.

    Output is deterministic: the same bytes on every run (fixed seeds, no timestamps).

    Parameters
    ----------
    directory : str or Path
        Created if missing.
    names : sequence of str, optional
        Reference names to export, default all of :data:`REFERENCE_BUILDERS`. The index
        lists the exported names.

    Returns
    -------
    list of Path
        The ``.qasm`` files in ``names`` order, then the index.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [p.name for p in export_circuits(tmp, ["pyramid_4"])]
    ['pyramid_4.qasm', 'README.md']
    """
    selected = _check_names(names)
    if not isinstance(directory, (str, Path)):
        raise TypeError(f"directory must be a str or Path, got {type(directory).__name__}")
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in selected:
        path = out / f"{name}.qasm"
        path.write_bytes(reference_qasm(name).encode("utf-8"))
        written.append(path)
    index = out / INDEX_NAME
    index.write_bytes(index_markdown(selected).encode("utf-8"))
    written.append(index)
    return written


# Numbers in OpenQASM text: angles ("-2.0344439357957027", "1.5e-05") and indices.
_NUMBER = re.compile(r"\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")
_REL_TOL = 1e-9
_ABS_TOL = 1e-12


def _same_text(written: str, expected: str) -> bool:
    """Whether two exported texts agree: identical, or identical up to angle round-off.

    The tolerant comparison keeps a file current when the last bits of an angle differ between
    platforms (``arctan2`` and friends are not correctly rounded everywhere); any change of a
    gate, a qubit, a register, a comment or an angle beyond ``1e-9`` relative still counts.
    """
    if written == expected:
        return True
    text_a, text_b = _NUMBER.split(written), _NUMBER.split(expected)
    nums_a, nums_b = _NUMBER.findall(written), _NUMBER.findall(expected)
    if text_a != text_b or len(nums_a) != len(nums_b):
        return False
    return all(
        math.isclose(float(a), float(b), rel_tol=_REL_TOL, abs_tol=_ABS_TOL)
        for a, b in zip(nums_a, nums_b, strict=True)
    )


def _read_text(path: Path) -> str | None:
    try:
        return path.read_bytes().decode("utf-8")
    except (FileNotFoundError, UnicodeDecodeError):
        return None


def check_circuits(directory: str | Path) -> list[str]:
    """Reference circuits whose exported files are missing or out of date.

    Parameters
    ----------
    directory : str or Path
        A directory written by :func:`export_circuits` (all reference circuits).

    Returns
    -------
    list of str
        In :data:`REFERENCE_BUILDERS` order: every name whose ``<name>.qasm`` is missing or
        differs from what :func:`export_circuits` would write now (angles are compared to
        ``1e-9`` relative, everything else exactly); then, sorted, the stem of every other
        ``.qasm`` file in the directory (a stale export of a circuit that no longer exists);
        then ``"README.md"`` if the index is missing or differs. Empty when all is current.

    Raises
    ------
    TypeError
        If ``directory`` is not a str or Path.
    ValueError
        If ``directory`` exists and is not a directory.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     _ = export_circuits(tmp)
    ...     check_circuits(tmp)
    []
    """
    if not isinstance(directory, (str, Path)):
        raise TypeError(f"directory must be a str or Path, got {type(directory).__name__}")
    root = Path(directory)
    if root.exists() and not root.is_dir():
        raise ValueError(f"directory must be a directory, got the file {str(root)!r}")
    stale = []
    for name in REFERENCE_BUILDERS:
        written = _read_text(root / f"{name}.qasm")
        if written is None or not _same_text(written, reference_qasm(name)):
            stale.append(name)
    if root.is_dir():
        extra = sorted(
            p.stem for p in root.glob("*.qasm") if p.stem not in REFERENCE_BUILDERS
        )
        stale.extend(extra)
    index = _read_text(root / INDEX_NAME)
    if index is None or index != index_markdown():
        stale.append(INDEX_NAME)
    return stale


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m qdensity.export [DIRECTORY] [--check]``.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``). ``DIRECTORY`` defaults to ``circuits`` in the
        working directory; ``--check`` writes nothing and reports out-of-date files.

    Returns
    -------
    int
        Exit status: 0, or 1 when ``--check`` finds out-of-date files.
    """
    parser = argparse.ArgumentParser(
        prog="python -m qdensity.export",
        description="Export qdensity's reference circuits as OpenQASM 2 with a README index.",
    )
    parser.add_argument("directory", nargs="?", default="circuits",
                        help="output directory (default: ./circuits)")
    parser.add_argument("--check", action="store_true",
                        help="write nothing; list missing or out-of-date files, exit 1 if any")
    args = parser.parse_args(argv)
    if args.check:
        stale = check_circuits(args.directory)
        for name in stale:
            print(f"out of date: {name}")
        if not stale:
            print(f"{args.directory}: all {len(REFERENCE_BUILDERS)} reference circuits current")
        return 1 if stale else 0
    paths = export_circuits(args.directory)
    print(f"wrote {len(paths) - 1} circuits and {INDEX_NAME} to {args.directory}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
