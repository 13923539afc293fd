"""Table 1 of the paper, counted by the gradient plans' own analyses.

For each ansatz and size, the original circuit and its density version are turned into
:class:`~qdensity.models.DensityQNN` s and their gradient circuits are counted by
:func:`~qdensity.gradients.gradient_circuit_count`: the plans' method choice, block analysis,
gradient-string grouping and shift rules, without building the circuits or parameter rows
(``density_gradient_plan(...).meta["gradient_circuits"]`` gives the same numbers; a test holds
them equal): distinct circuit executions for the full gradient of one data point, forward pass
excluded.

=================== ======================= ==================================================
ansatz              original (method)       density version (method)
=================== ======================= ==================================================
hardware_efficient  D layers, shift         one sub-unitary per layer, commuting (D circuits)
equivariant_xx      commuting (1 circuit)   K independent copies, commuting (K circuits)
pyramid             shift, 4 per RBS        odd-even split (Supp. H.1), commuting (2)
butterfly           shift, 4 per RBS        one sub-unitary per layer, commuting (log2 n)
round_robin         shift, 4 per RBS        one sub-unitary per layer, commuting (n - 1)
=================== ======================= ==================================================

Observables: ``Z_0`` for the hardware-efficient and equivariant rows (a single Pauli string, the
setting of Bowles et al.'s Theorem 1; with ``sum_i Z_i`` their gradient observables do not all
commute and the commuting method needs several circuits per block) and ``sum_i Z_i`` for the
Hamming-weight-preserving rows.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    butterfly,
    equivariant_commuting,
    hardware_efficient,
    pyramid,
    round_robin,
)
from qdensity.circuits.ansatze.registry import FAMILIES
from qdensity.gradients.density import gradient_circuit_count
from qdensity.models.compression import compressed_odd_even
from qdensity.models.decompositions import by_moments, copies, odd_even
from qdensity.models.density import DensityQNN
from qdensity.progress import progress_bar
from qdensity.validation import check_positive_int

__all__ = ["ANSATZE", "table1_row", "table1", "format_table1"]

#: The rows of the paper's Table 1: ansatz families of the registry
#: (:data:`~qdensity.circuits.ansatze.registry.FAMILIES`).
ANSATZE = ("hardware_efficient", "equivariant_xx", "pyramid", "butterfly", "round_robin")


def _z(n: int, qubits) -> SparsePauliOp:
    return SparsePauliOp.from_sparse_list([("Z", [q], 1.0) for q in qubits], n)


@contextmanager
def _cyclic_gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector (restored after, as it was).

    A row at n = 64 creates a few hundred thousand gate objects that stay alive until it ends;
    the collector re-scans them on every full collection as the heap grows, about a third of
    the row's time (equivariant_xx at n = 64: 6.6 s with it, 4.7 s without). Nothing here
    relies on it: reference counting frees the row's objects, and any cycles are collected
    once it runs again.
    """
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _count(subs, observable, method: str) -> tuple[int, int, int]:
    model = DensityQNN(subs, observable=observable)
    return (model.num_parameters, gradient_circuit_count(model, method=method),
            model.num_subunitaries)


def table1_row(ansatz: str, num_qubits: int, *, layers: int = 3, copies_k: int = 2) -> dict:
    """One row of Table 1 for ``ansatz`` on ``num_qubits`` qubits.

    Parameters
    ----------
    ansatz : str
        One of :data:`ANSATZE`.
    num_qubits : int
    layers : int
        D for the hardware-efficient ansatz.
    copies_k : int
        K for the equivariant density version.

    Returns
    -------
    dict
        ``{"ansatz", "n", "observable", "original": {"params", "gradient_circuits", "method"},
        "density": {"params", "gradient_circuits", "sub_unitaries", "decomposition"},
        "compressed": {"params", "gradient_circuits"} or None}``. ``compressed`` is the
        compressed density version (each pair's run of RBS gates merged into one angle,
        :func:`~qdensity.models.compression.compressed_odd_even`), given for the pyramid: the
        paper's Table 1 states ``O(n)`` parameters for the density pyramid, which holds for
        this version (``n - 1``), while the uncompressed one keeps ``n (n - 1) / 2``.

    Examples
    --------
    The round-robin ansatz on 4 qubits: 6 RBS gates, 4 shifted circuits each; its density
    version (one sub-unitary per layer) needs one commuting circuit per layer, ``n - 1``:

    >>> from qdensity.gradients.table1 import table1_row
    >>> row = table1_row("round_robin", 4)
    >>> row["original"], row["density"]["gradient_circuits"]
    ({'params': 6, 'gradient_circuits': 24, 'method': 'shift'}, 3)
    """
    n = check_positive_int(num_qubits, "num_qubits", minimum=2)
    if ansatz not in ANSATZE:
        raise ValueError(f"ansatz must be one of {ANSATZE}, got {ansatz!r}")
    with _cyclic_gc_paused():
        return _row(ansatz, n, layers, copies_k)


def _row(ansatz: str, n: int, layers: int, copies_k: int) -> dict:
    if ansatz == "hardware_efficient":
        circ, obs, obs_name = hardware_efficient(n, layers), _z(n, [0]), "Z0"
        dec = by_moments(circ)
    elif ansatz == "equivariant_xx":
        circ, obs, obs_name = equivariant_commuting(n, "X"), _z(n, [0]), "Z0"
        dec = copies(circ, copies_k)
    elif ansatz == "pyramid":
        circ, obs, obs_name = pyramid(n), _z(n, range(n)), "sum Z"
        dec = odd_even(circ)
    elif ansatz == "butterfly":
        circ, obs, obs_name = butterfly(n), _z(n, range(n)), "sum Z"
        dec = by_moments(circ)
    else:  # round_robin (table1_row checked the name)
        circ, obs, obs_name = round_robin(n), _z(n, range(n)), "sum Z"
        dec = by_moments(circ)
    method = FAMILIES[ansatz].gradient  # the family's own gradient method (its registry entry)
    p0, g0, _ = _count([circ], obs, method)
    p1, g1, k = _count(dec.sub_unitaries, obs, "commuting")
    compressed = None
    if ansatz == "pyramid":  # the paper's O(n) parameters hold for the compressed version only
        p2, g2, _ = _count(compressed_odd_even(circ).sub_unitaries, obs, "commuting")
        compressed = {"params": p2, "gradient_circuits": g2}
    return {
        "ansatz": ansatz,
        "n": n,
        "observable": obs_name,
        "original": {"params": p0, "gradient_circuits": g0, "method": method},
        "density": {"params": p1, "gradient_circuits": g1, "sub_unitaries": k,
                    "decomposition": dec.name},
        "compressed": compressed,
    }


def table1(sizes=(4, 8), ansatze=ANSATZE, *, layers: int = 3, copies_k: int = 2,
           verbose: bool = True) -> list[dict]:
    """Rows of Table 1 for every ansatz and size (butterfly only for powers of two).

    ``verbose``: on a terminal, a ``table1`` bar counts the rows done and names the row in
    progress (see :mod:`qdensity.progress`); False: silent.

    Examples
    --------
    The butterfly needs a power of two, so its 6-qubit row is left out:

    >>> from qdensity.gradients.table1 import table1
    >>> rows = table1(sizes=(4, 6), ansatze=("butterfly", "round_robin"), verbose=False)
    >>> [(r["ansatz"], r["n"], r["density"]["gradient_circuits"]) for r in rows]
    [('butterfly', 4, 2), ('round_robin', 4, 3), ('round_robin', 6, 5)]
    """
    todo = [(name, n) for name in ansatze for n in sizes
            if not (name in FAMILIES and FAMILIES[name].power_of_two and n & (n - 1))]
    rows = []
    with progress_bar(len(todo), desc="table1", unit="row", verbose=verbose,
                      leave=True) as bar:
        for name, n in todo:
            bar.set_postfix(ansatz=name, n=n, refresh=False)
            rows.append(table1_row(name, n, layers=layers, copies_k=copies_k))
            bar.update()
    return rows


def format_table1(rows: list[dict]) -> str:
    """Fixed-width text table of :func:`table1` rows.

    Examples
    --------
    Three header lines, then one line per row (the pyramid's with its compressed version):

    >>> from qdensity.gradients.table1 import format_table1, table1
    >>> text = format_table1(table1(sizes=(4,), ansatze=("pyramid",), verbose=False))
    >>> text.splitlines()[3].split()
    ['pyramid', '4', 'sum', 'Z', '6', '24', '2', '6', '2', '12.0', '3', '2']
    """
    head = (f"{'ansatz':<20}{'n':>4}  {'obs':<6}{'params':>8}{'grad circ':>11}"
            f"{'K':>5}{'params':>8}{'grad circ':>11}{'ratio':>8}{'params':>9}{'grad circ':>11}")
    lines = [f"{'':<30}{'original':>19}{'density':>24}{'compressed density':>28}", head,
             "-" * len(head)]
    for r in rows:
        o, d = r["original"], r["density"]
        ratio = o["gradient_circuits"] / max(d["gradient_circuits"], 1)
        lines.append(
            f"{r['ansatz']:<20}{r['n']:>4}  {r['observable']:<6}{o['params']:>8}"
            f"{o['gradient_circuits']:>11}{d['sub_unitaries']:>5}{d['params']:>8}"
            f"{d['gradient_circuits']:>11}{ratio:>8.1f}"
            + (f"{c['params']:>9}{c['gradient_circuits']:>11}" if (c := r.get("compressed"))
               else f"{'-':>9}{'-':>11}")
        )
    return "\n".join(lines)
