"""Unary loaders vs. Qiskit's generic ``StatePreparation`` after transpiling (docs/design.md,
"Measured facts").

For seeded random vectors of length d = 4, 8, 16, each unary loader (parallel, diagonal,
semi-diagonal) and ``StatePreparation`` of the same 2**d-dimensional unary state (on d qubits)
are transpiled to ``["cz", "rz", "sx", "x"]`` at optimisation level 3. The table lists the
two-qubit gate count, the depth, and the ratio of StatePreparation's two-qubit count to the
method's. Every transpiled loader (and StatePreparation up to d = 10) is checked on Aer to
prepare the target state before it is counted.

Run: ``python benchmarks/bench_loaders.py`` (one to two minutes: transpiling StatePreparation at
d = 16, about 65k CZ, dominates).
"""

from __future__ import annotations

import time

import numpy as np
from qiskit import QuantumCircuit, transpile
from qiskit.circuit.library import StatePreparation
from qiskit_aer import AerSimulator

from qdensity.circuits.loaders import LAYOUTS, unary_loader

BASIS = ["cz", "rz", "sx", "x"]
LENGTHS = (4, 8, 16)
SEED = 2024
#: StatePreparation's output is simulated up to this width; at d = 16 its ~365k transpiled
#: gates take longer to simulate than to transpile (loaders are always checked).
MAX_CHECKED_PREP = 10
_SIM = AerSimulator(method="statevector")


def _two_qubit_count(circuit: QuantumCircuit) -> int:
    return sum(1 for inst in circuit.data if inst.operation.num_qubits == 2)


def _unary_state(x: np.ndarray) -> np.ndarray:
    out = np.zeros(2**x.size)
    out[2 ** np.arange(x.size)] = x / np.linalg.norm(x)
    return out


def _measure(circuit: QuantumCircuit, target: np.ndarray, seed: int, *, check: bool) -> dict:
    start = time.perf_counter()
    tqc = transpile(circuit, basis_gates=BASIS, optimization_level=3, seed_transpiler=seed)
    seconds = time.perf_counter() - start
    if check:
        verify = tqc.copy()
        verify.save_statevector()
        state = np.asarray(_SIM.run(verify).result().get_statevector())
        fidelity = abs(np.vdot(target, state)) ** 2
        if fidelity < 1 - 1e-8:
            raise RuntimeError(f"{circuit.name}: transpiled circuit has fidelity {fidelity}")
    return {"two_qubit": _two_qubit_count(tqc), "depth": tqc.depth(), "transpile_s": seconds}


def main(lengths=LENGTHS, seed: int = SEED) -> list[dict]:
    """Measure every method at every length; print the table and return its rows.

    Parameters
    ----------
    lengths : sequence of int
        Vector lengths ``d`` (qubits).
    seed : int
        Seeds the vectors and the transpiler.

    Returns
    -------
    list of dict
        Keys ``length, method, two_qubit, depth, transpile_s, ratio`` where ``ratio`` is
        StatePreparation's two-qubit count divided by the method's.
    """
    rng = np.random.default_rng(seed)
    rows: list[dict] = []
    for d in lengths:
        x = rng.normal(size=d)
        target = _unary_state(x)
        prep = QuantumCircuit(d, name="state_preparation")
        prep.append(StatePreparation(target), range(d))
        reference = {"length": d, "method": "StatePreparation",
                     **_measure(prep, target, seed, check=d <= MAX_CHECKED_PREP)}
        block = [reference]
        for layout in LAYOUTS:
            loader = unary_loader(x, layout)
            block.append({"length": d, "method": f"loader/{layout}",
                          **_measure(loader, target, seed, check=True)})
        for row in block:
            row["ratio"] = reference["two_qubit"] / row["two_qubit"]
        rows += block

    header = f"{'length':>6}  {'method':<22}{'2q gates':>10}{'depth':>9}{'SP/method':>11}{'s':>8}"
    print(header)
    print("-" * len(header))
    for r in rows:
        print(f"{r['length']:>6}  {r['method']:<22}{r['two_qubit']:>10}{r['depth']:>9}"
              f"{r['ratio']:>11.1f}{r['transpile_s']:>8.2f}")
    at8 = [r for r in rows if r["length"] == 8 and r["method"].startswith("loader")]
    if at8:
        worst = min(r["ratio"] for r in at8)
        verdict = "met" if worst >= 10 else "NOT met"
        print(f"\ntarget (>= 10x fewer two-qubit gates at length 8): {verdict}, "
              f"worst ratio {worst:.1f}x")
    return rows


if __name__ == "__main__":
    main()
