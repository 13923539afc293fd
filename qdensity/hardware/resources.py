"""Resource reports: what a circuit costs once compiled for a target.

The paper argues in gate counts and depths (Sec. 3 and Table 1: loaders, pyramids and butterflies
of RBS gates, each RBS two native two-qubit gates). :func:`resource_report` compiles a circuit
once for a :class:`~qdensity.hardware.targets.HardwareTarget` and reads off the numbers that matter
on
hardware: active qubits, depth, the two-qubit gate count and the two-qubit depth.
:func:`compare_reports` prints several reports side by side with ratios to the first.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from qiskit.circuit import ControlFlowOp, QuantumCircuit, Store

from qdensity.hardware.snapshot_files import is_snapshot_path
from qdensity.hardware.targets import as_target, get_target
from qdensity.validation import (
    Circuit,
    Instance,
    Interval,
    Options,
    Seed,
    SeedLike,
    TargetLike,
    validates,
)

__all__ = ["ResourceReport", "resource_report", "compare_reports", "METRICS", "DEFAULT_BASIS"]

#: Scalar metrics of a :class:`ResourceReport`, in table order.
METRICS = ("num_qubits", "depth", "two_qubit_count", "two_qubit_depth")

#: Basis of the default ("ideal") target of :func:`resource_report`.
DEFAULT_BASIS = ("cz", "rz", "sx", "x")

_IGNORED = frozenset({"barrier", "delay"})


@validates(
    name=Instance(str), target=Instance(str), num_qubits=Interval(int, 0), depth=Interval(int, 0),
    two_qubit_count=Interval(int, 0), two_qubit_depth=Interval(int, 0), gate_counts=Instance(dict),
)
@dataclass(frozen=True)
class ResourceReport:
    """Costs of one compiled circuit.

    Attributes
    ----------
    name : str
        The circuit's name.
    target : str
        Label of the target it was compiled for (``HardwareTarget.label``: the name, e.g.
        ``"line"``, or ``"ideal[cz,rz,sx,x]"`` for an ideal target with a custom basis).
    num_qubits : int
        Active qubits: those touched by a gate or a measurement (idle device qubits excluded).
    depth : int
        Circuit depth (measurements included, barriers excluded).
    two_qubit_count : int
        Number of two-qubit gates.
    two_qubit_depth : int
        Depth counting only two-qubit gates (three CZs in sequence on one pair: 3; CZs on
        disjoint pairs: 1).
    gate_counts : dict of str to int
        Instruction counts by name (barriers excluded), sorted by name.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.hardware import resource_report
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.h(0); _ = qc.cx(0, 1)
    >>> rep = resource_report(qc, "all_to_all")
    >>> isinstance(rep, ResourceReport), rep.two_qubit_count, rep.num_qubits
    (True, 1, 2)
    """

    name: str
    target: str
    num_qubits: int
    depth: int
    two_qubit_count: int
    two_qubit_depth: int
    gate_counts: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The report as a plain dict (``gate_counts`` copied)."""
        return {
            "name": self.name,
            "target": self.target,
            "num_qubits": self.num_qubits,
            "depth": self.depth,
            "two_qubit_count": self.two_qubit_count,
            "two_qubit_depth": self.two_qubit_depth,
            "gate_counts": dict(self.gate_counts),
        }

    def rows(self) -> list[tuple[str, int]]:
        """``(metric, value)`` rows: :data:`METRICS`, then ``gates[<name>]`` per gate."""
        out = [(m, getattr(self, m)) for m in METRICS]
        out += [(f"gates[{g}]", c) for g, c in self.gate_counts.items()]
        return out

    def table(self) -> str:
        """A fixed-width text table of every metric and gate count.

        Returns
        -------
        str
            A title line ``"<name> on <target>"``, a header and one row per metric.
        """
        rows = [(m, str(v)) for m, v in self.rows()]
        return f"{self.name} on {self.target}\n" + _format_table(["metric", "value"], rows)

    def __str__(self) -> str:
        return self.table()


def _size_for(target, width: int) -> int | None:
    """The size to ask a named target for; None for devices of fixed size (their width is
    checked against the circuit's by ``transpile``)."""
    return width if isinstance(target, str) and not is_snapshot_path(target) else None


@validates(
    circuit=Circuit(), target=[TargetLike(), None], optimization_level=Options((0, 1, 2, 3)),
    seed=Seed(), transpiled=Instance(bool),
)
def resource_report(
    circuit: QuantumCircuit,
    target=None,
    *,
    optimization_level: int = 1,
    seed: SeedLike = 0,
    transpiled: bool = False,
) -> ResourceReport:
    """Compile ``circuit`` once for ``target`` and count its resources.

    Parameters
    ----------
    circuit : QuantumCircuit
        Any circuit (parameters may stay free).
    target : HardwareTarget, str, os.PathLike, BackendV2, qiskit.transpiler.Target or None
        A target, or anything :func:`~qdensity.hardware.targets.get_target` accepts: a name (sized
        to
        the circuit), a snapshot file, a backend or a ``Target`` (seeded with ``seed``, built
        without its noise model, which does not change counts). A device narrower than the
        circuit is refused before transpiling, naming both widths.
        Default: the noiseless ``"ideal"`` all-to-all target with basis
        ``("cz", "rz", "sx", "x")`` (the name ``"ideal"`` alone keeps every standard gate).
    optimization_level : int, optional
        Transpiler optimisation level, 0 to 3. Default 1.
    seed : int, numpy.random.Generator or None, optional
        Transpiler seed (the report is reproducible). Default 0.
    transpiled : bool, optional
        If True, ``circuit`` is taken as already compiled for ``target`` and counted as is.

    Returns
    -------
    ResourceReport

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.circuits.gates import RBSGate
    >>> qc = QuantumCircuit(3, name="chain")
    >>> _ = qc.append(RBSGate(0.3), [0, 1])
    >>> _ = qc.append(RBSGate(0.5), [1, 2])
    >>> rep = resource_report(qc)
    >>> rep.two_qubit_count, rep.two_qubit_depth
    (4, 4)
    >>> resource_report(qc, "rbs_native").two_qubit_count
    2
    """
    if target is None:
        hw = get_target("ideal", max(circuit.num_qubits, 1), seed=seed, basis_gates=DEFAULT_BASIS)
    else:
        # noise does not change counts and costs time to build: leave it off
        hw = as_target(target, _size_for(target, circuit.num_qubits), seed=seed, noise=False)
    if transpiled:
        compiled = circuit
    else:
        compiled = hw.transpile(circuit, optimization_level=optimization_level, seed=seed)
    return _count(compiled, name=circuit.name, target=hw.label)


@validates(reports=Instance(Mapping, 'mapping of names to ResourceReport'),
           width=Interval(int, 40, 10_000))
def compare_reports(reports: Mapping[str, ResourceReport], *, width: int = 100) -> str:
    """Side-by-side table of several reports, with ratios to the first.

    Parameters
    ----------
    reports : mapping of str to ResourceReport
        Column name -> report, in column order; the first is the reference.
    width : int
        Widest line (``>= 40``). A table wider than this names its columns ``[1]``, ``[2]``,
        ... under a legend of the report names, and is cut into blocks of columns (each
        repeating the metric column) that fit.

    Returns
    -------
    str
        Rows are :data:`METRICS` and ``gates[<name>]`` for every gate in any report; columns
        are the reports, then one ratio column ``"<name>/<first>"`` per other report
        (``n/a`` for 0/0, ``inf`` for x/0); no line longer than ``width``.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> qc = QuantumCircuit(3)
    >>> _ = qc.cx(0, 1)
    >>> _ = qc.cx(0, 2)
    >>> text = compare_reports({"ideal": resource_report(qc), "line": resource_report(qc, "line")})
    """
    if not reports:
        raise ValueError("reports must hold at least one ResourceReport")
    width = int(width)
    for key, rep in reports.items():
        if not isinstance(key, str):
            raise TypeError(f"reports keys must be str, got {key!r}")
        if not isinstance(rep, ResourceReport):
            raise TypeError(f"reports[{key!r}] must be a ResourceReport, got {type(rep).__name__}")
    names = list(reports)
    first = names[0]
    gates = sorted({g for rep in reports.values() for g in rep.gate_counts})
    metrics = [*METRICS, *(f"gates[{g}]" for g in gates)]

    def value(rep: ResourceReport, metric: str) -> int:
        if metric.startswith("gates["):
            return rep.gate_counts.get(metric[6:-1], 0)
        return getattr(rep, metric)

    header = ["metric", *names, *(f"{n}/{first}" for n in names[1:])]
    rows = []
    for metric in metrics:
        values = [value(reports[n], metric) for n in names]
        ratios = [_ratio(v, values[0]) for v in values[1:]]
        rows.append((metric, *map(str, values), *ratios))
    text = _format_table(header, rows)
    if max(len(line) for line in text.splitlines()) <= width:
        return text
    labels = [f"[{i + 1}]" for i in range(len(names))]
    legend = [f"{label} {name}"[:width] for label, name in zip(labels, names, strict=True)]
    header = ["metric", *labels, *(f"{lab}/{labels[0]}" for lab in labels[1:])]
    return "\n".join(legend) + "\n\n" + _format_blocks(header, rows, width)


# ----------------------------------------------------------------------------------------------


def _count(circuit: QuantumCircuit, *, name: str, target: str) -> ResourceReport:
    """Read the metrics off a compiled circuit in one pass over its instructions.

    The depths are ``QuantumCircuit.depth`` (directives such as barriers do not add a layer but
    still synchronise their wires) and ``QuantumCircuit.depth`` filtered to two-qubit gates,
    computed together on integer wire indices; a circuit with classical conditions, control
    flow or stores is handed to ``QuantumCircuit.depth`` itself.
    """
    wire = {bit: k for k, bit in enumerate(circuit.qubits)}
    num_qubits = len(wire)
    wire.update((bit, num_qubits + k) for k, bit in enumerate(circuit.clbits))
    level = [0] * len(wire)      # depth so far on each wire
    level_2q = [0] * len(wire)   # two-qubit depth so far on each wire
    active: set[int] = set()
    two_qubit = 0
    counts: dict[str, int] = {}
    plain = True
    for inst in circuit.data:
        op = inst.operation
        if plain and isinstance(op, (ControlFlowOp, Store)):  # (qiskit 2 has no c_if)
            plain = False  # wires beyond qubits and clbits: let Qiskit count the depths
        wires = [wire[q] for q in inst.qubits]
        op_name = op.name
        if op_name not in _IGNORED:
            counts[op_name] = counts.get(op_name, 0) + 1
            active.update(wires)
        is_2q = len(wires) == 2 and op_name not in _IGNORED
        if is_2q:
            two_qubit += 1
        if not plain:
            continue
        wires += [wire[c] for c in inst.clbits]
        if not wires:
            continue
        new = max(level[w] for w in wires) + (0 if inst.is_directive() else 1)
        new_2q = max(level_2q[w] for w in wires) + is_2q
        for w in wires:
            level[w] = new
            level_2q[w] = new_2q
    if plain:
        depth, depth_2q = max(level, default=0), max(level_2q, default=0)
    else:
        def is_two_qubit_gate(inst) -> bool:
            return len(inst.qubits) == 2 and inst.operation.name not in _IGNORED

        depth, depth_2q = circuit.depth(), circuit.depth(filter_function=is_two_qubit_gate)
    return ResourceReport(
        name=name,
        target=target,
        num_qubits=len(active),
        depth=depth,
        two_qubit_count=two_qubit,
        two_qubit_depth=depth_2q,
        gate_counts=dict(sorted(counts.items())),
    )


def _ratio(value: int, reference: int) -> str:
    if reference == 0:
        return "n/a" if value == 0 else "inf"
    return f"{value / reference:.2f}"


def _format_blocks(header: list[str], rows: list[tuple[str, ...]], width: int) -> str:
    """:func:`_format_table` cut into blocks of columns (the first repeated in each) whose
    lines fit ``width``; blocks separated by a blank line."""
    widths = [max(len(str(r[k])) for r in [header, *rows]) for k in range(len(header))]
    blocks: list[list[int]] = []
    current: list[int] = []
    used = widths[0]
    for k in range(1, len(header)):
        if current and used + 2 + widths[k] > width:
            blocks.append(current)
            current, used = [], widths[0]
        current.append(k)
        used += 2 + widths[k]
    blocks.append(current)
    return "\n\n".join(_format_table([header[0], *(header[k] for k in cols)],
                                      [(r[0], *(r[k] for k in cols)) for r in rows])
                         for cols in blocks)


def _format_table(header: list[str], rows: Sequence[tuple[str, ...]]) -> str:
    """Left-aligned first column, right-aligned others, a dashed rule under the header."""
    widths = [max(len(str(r[k])) for r in [header, *rows]) for k in range(len(header))]

    def line(cells) -> str:
        parts = [str(cells[0]).ljust(widths[0])]
        parts += [str(c).rjust(w) for c, w in zip(cells[1:], widths[1:], strict=True)]
        return "  ".join(parts).rstrip()

    rule = "  ".join("-" * w for w in widths)
    return "\n".join([line(header), rule, *(line(r) for r in rows)])
