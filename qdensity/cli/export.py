"""Writing and checking the ``circuits/`` directory of reference circuits, and its command line.

:func:`export_circuits` writes ``<name>.qasm`` (OpenQASM 2, parameters bound) and
``<name>.qasm3`` (OpenQASM 3, trainable and data parameters symbolic) for every reference
circuit of
:mod:`qdensity.cli.reference` (the catalogue: loaders, ansätze, the density-QNN preparations of
Fig. 1 and Fig. 13b, a gradient circuit of Methods eq. 9, the tomography circuits of Supp. F)
and a ``README.md`` index (:func:`index_markdown`); :func:`check_circuits` lists the files that
are missing or out of date. Regenerate the directory with ``qdensity export`` or
``python -m qdensity.cli.export [DIR]`` (:func:`main`).

The catalogue's names are re-exported here, so ``from qdensity.cli.export import reference_qasm``
keeps working.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path

from qdensity.cli.reference import (
    QASM2_BASIS,
    REFERENCE_BUILDERS,
    REFERENCE_DESCRIPTIONS,
    _check_names,
    _exported,
    _exported3,
    bind_reference,
    reference_circuit,
    reference_qasm,
    reference_qasm3,
    reference_seed,
    symbolic_circuit,
)
from qdensity.io import atomic_write_bytes, check_readable

__all__ = [
    "QASM2_BASIS",
    "INDEX_NAME",
    "REFERENCE_BUILDERS",
    "REFERENCE_DESCRIPTIONS",
    "reference_seed",
    "bind_reference",
    "reference_circuit",
    "reference_qasm",
    "reference_qasm3",
    "symbolic_circuit",
    "export_circuits",
    "check_circuits",
    "index_markdown",
    "main",
]

#: Name of the index written next to the ``.qasm`` files.
INDEX_NAME = "README.md"


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
        a one-line description and the OpenQASM 3 file with its number of symbolic
        parameters, followed by how to regenerate and check the files.

    Examples
    --------
    >>> text = index_markdown(["pyramid_4"])
    >>> text.splitlines()[0], "pyramid_4.qasm" in text
    ('# Reference circuits', True)
    """
    rows = []
    for name in _check_names(names):
        _, qubits, two_qubit, depth = _exported(name)
        free = _exported3(name)[1]
        rows.append(
            f"| [`{name}.qasm`]({name}.qasm) | {qubits} | {two_qubit} | {depth} | "
            f"{REFERENCE_DESCRIPTIONS[name]} | [`{name}.qasm3`]({name}.qasm3) ({free}) |"
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
        "Each circuit is also exported as OpenQASM 3 (`<name>.qasm3`, gates of",
        "`stdgates.inc`) with its trainable angles and the data angles of its unary loaders",
        "kept symbolic: one `input float[64]` per parameter, in the circuit's parameter order",
        "(the number in brackets), for a provider to bind. They reload with",
        "`qiskit.qasm3.loads` (`pip install qiskit-qasm3-import`).",
        "",
        "| file | qubits | two-qubit gates | depth | description | OpenQASM 3 (parameters) |",
        "|---|---:|---:|---:|---|---|",
        *rows,
        "",
        "## Regenerate",
        "",
        "These files are generated; do not edit them by hand. Regenerate with",
        "",
        "```",
        "qdensity export            # both formats; --qasm3 writes only the OpenQASM 3 files",
        "```",
        "",
        "or `python -m qdensity.cli.export [DIRECTORY]` (default `./circuits`). The test suite",
        "checks that the files are current (`qdensity.cli.export.check_circuits`) and that each",
        "reloads to its builder's operator.",
        "",
    ]
    return "\n".join(lines)


def export_circuits(directory: str | Path, names: Sequence[str] | None = None, *,
                    formats: Sequence[str] = ("qasm", "qasm3")) -> list[Path]:
    """Write ``<name>.qasm`` and ``<name>.qasm3`` for each reference circuit, and the index.

    Output is deterministic: the same bytes on every run (fixed seeds, no timestamps).

    Parameters
    ----------
    directory : str or Path
        Created if missing.
    names : sequence of str, optional
        Reference names to export, default all of :data:`REFERENCE_BUILDERS`. The index
        lists the exported names.
    formats : sequence of {"qasm", "qasm3"}
        OpenQASM 2 (bound parameters) and/or OpenQASM 3 (symbolic parameters); default both.

    Returns
    -------
    list of Path
        The ``.qasm`` files in ``names`` order, then the ``.qasm3`` files, then the index.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [p.name for p in export_circuits(tmp, ["pyramid_4"])]
    ['pyramid_4.qasm', 'pyramid_4.qasm3', 'README.md']
    """
    selected = _check_names(names)
    if isinstance(formats, str) or not set(formats) <= set(_WRITERS) or not formats:
        raise ValueError(f"formats must be a non-empty sequence of {list(_WRITERS)}, "
                         f"got {formats!r}")
    if not isinstance(directory, (str, Path)):
        raise TypeError(f"directory must be a str or Path, got {type(directory).__name__}")
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for suffix in (f for f in _WRITERS if f in formats):
        for name in selected:
            path = out / f"{name}.{suffix}"
            atomic_write_bytes(path, _WRITERS[suffix](name).encode("utf-8"))
            written.append(path)
    index = out / INDEX_NAME
    atomic_write_bytes(index, index_markdown(selected).encode("utf-8"))
    written.append(index)
    return written


_WRITERS = {"qasm": reference_qasm, "qasm3": reference_qasm3}

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
    try:  # a FIFO or device in its place, or a huge file, is not the export: unreadable
        return check_readable(path, max_bytes=2**26).read_bytes().decode("utf-8")
    except (FileNotFoundError, UnicodeDecodeError, ValueError):
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
        then the same for the OpenQASM 3 files, as ``"<name>.qasm3"``; then ``"README.md"``
        if the index is missing or differs. Empty when all is current.

    Raises
    ------
    TypeError
        If ``directory`` is not a str or Path.
    ValueError
        If ``directory`` does not exist or is not a directory.

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
    if not root.exists():
        raise ValueError(f"directory {str(root)!r} does not exist (write it with "
                         "export_circuits or `qdensity export DIR` first)")
    if not root.is_dir():
        raise ValueError(f"directory must be a directory, got the file {str(root)!r}")
    stale = []
    for suffix, writer in _WRITERS.items():
        tag = "" if suffix == "qasm" else f".{suffix}"
        for name in REFERENCE_BUILDERS:
            written = _read_text(root / f"{name}.{suffix}")
            if written is None or not _same_text(written, writer(name)):
                stale.append(f"{name}{tag}")
        if root.is_dir():
            stale.extend(sorted(f"{p.stem}{tag}" for p in root.glob(f"*.{suffix}")
                                if p.stem not in REFERENCE_BUILDERS))
    index = _read_text(root / INDEX_NAME)
    if index is None or index != index_markdown():
        stale.append(INDEX_NAME)
    return stale


def main(argv: Sequence[str] | None = None, *, prog: str = "python -m qdensity.cli.export") -> int:
    """Command line: ``python -m qdensity.cli.export [DIRECTORY] [--check]``.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``). ``DIRECTORY`` defaults to ``circuits`` in the
        working directory; ``--check`` writes nothing and reports out-of-date files.
    prog : str
        Program name in messages.

    Returns
    -------
    int
        Exit status: 0, 1 when ``--check`` finds out-of-date files, 2 when the directory is
        missing or not a directory.

    Examples
    --------
    ``--check`` on a directory that does not exist writes nothing and exits with status 2:

    >>> main(["/no/such/directory", "--check"])
    2
    """
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Export qdensity's reference circuits as OpenQASM 2 and 3 with a README index.",
    )
    parser.add_argument("directory", nargs="?", default="circuits",
                        help="output directory (default: ./circuits)")
    parser.add_argument("--check", action="store_true",
                        help="write nothing; list missing or out-of-date files, exit 1 if any")
    parser.add_argument("--qasm3", action="store_true",
                        help="write only the OpenQASM 3 files (symbolic parameters) and index")
    args = parser.parse_args(argv)
    if args.check:
        try:
            stale = check_circuits(args.directory)
        except ValueError as exc:
            print(f"{parser.prog}: error: {exc}", file=sys.stderr)
            return 2
        for name in stale:
            print(f"out of date: {name}")
        if not stale:
            print(f"{args.directory}: all {len(REFERENCE_BUILDERS)} reference circuits current")
        return 1 if stale else 0
    formats = ("qasm3",) if args.qasm3 else ("qasm", "qasm3")
    paths = export_circuits(args.directory, formats=formats)
    print(f"wrote {len(paths) - 1} files and {INDEX_NAME} to {args.directory}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
