"""Unary engine vs Aer statevector: pyramid forward pass over a batch of unary inputs.

For each n, a batch of random unit inputs goes through the pyramid ansatz (paper Fig. 9a) with
shared random angles:

* unary engine: ``qdensity.execution.unary.forward`` on a compiled circuit (the n x n orthogonal
matrix,
  paper Methods), inputs given directly as amplitudes;
* Aer: ``AerSimulator(method="statevector")`` runs ONE job of a transpiled template (a gate-level
  unary loader -- X then a chain of RBS gates -- followed by the pyramid and a
  ``save_amplitudes`` of the n unary entries) with one ``parameter_binds`` row per input.
  Template transpilation is done once and reported separately. Aer runs single-threaded by
  default (``--aer-threads``), like the numpy engine; more threads help Aer at large n on an
  idle machine and hurt badly on a shared one (OpenMP spin-waiting).

Both outputs are compared (max abs difference) so the table is also a correctness check.
Aer at n = 20 runs 256 statevectors of 2^20 amplitudes: minutes on a small machine
(``--max-n 16`` for a quick run).

Run::

    python benchmarks/bench_unary_engine.py [--max-n 16] [--batch 256] [--aer-threads 1]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from qiskit import QuantumCircuit, transpile
from qiskit.circuit import ParameterVector
from qiskit_aer import AerSimulator

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.gates import RBSGate
from qdensity.execution.unary import compile_unary, forward

SIZES = (8, 12, 16, 20)


def chain_loader(n: int) -> QuantumCircuit:
    """Unary loader: X on qubit 0, RBS(x_k) on (k, k + 1); data angles in ParameterVector "x"."""
    x = ParameterVector("x", n - 1)
    qc = QuantumCircuit(n, name="chain_loader")
    qc.x(0)
    for k in range(n - 1):
        qc.append(RBSGate(x[k]), [k, k + 1])
    return qc


def chain_angles(X: np.ndarray) -> np.ndarray:
    """Loader angles (B, n - 1) for unit rows X (B, n): cos(x_k) = X_k / ||X_{k:}||."""
    tails = np.sqrt(np.cumsum((X**2)[:, ::-1], axis=1)[:, ::-1])
    angles = np.arctan2(tails[:, 1:], X[:, :-1])
    angles[:, -1] = np.arctan2(X[:, -1], X[:, -2])
    return angles


def best_of(fn, repeats: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def run(n: int, batch: int, rng: np.random.Generator, repeats: int, aer_threads: int) -> dict:
    X = rng.normal(size=(batch, n))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    ansatz = pyramid(n)
    theta = rng.uniform(-np.pi, np.pi, ansatz.num_parameters)

    start = time.perf_counter()
    compiled = compile_unary(ansatz)
    compile_s = time.perf_counter() - start
    unary_s, Y_unary = best_of(lambda: forward(compiled, X, theta), repeats)

    loader = chain_loader(n)
    template = loader.compose(ansatz)
    template.save_amplitudes([2**j for j in range(n)])
    sim = AerSimulator(method="statevector", max_parallel_threads=aer_threads)
    start = time.perf_counter()
    tqc = transpile(template, sim, optimization_level=1, seed_transpiler=0)
    transpile_s = time.perf_counter() - start

    angles = chain_angles(X)
    binds = {p: angles[:, k] for k, p in enumerate(loader.parameters)}
    binds.update({p: np.full(batch, theta[k]) for k, p in enumerate(ansatz.parameters)})
    binds = {p: v for p, v in binds.items() if p in tqc.parameters}

    def aer_forward():
        result = sim.run(tqc, parameter_binds=[binds], shots=1).result()
        return np.array([result.data(b)["amplitudes"] for b in range(batch)]).real

    aer_s, Y_aer = best_of(aer_forward, 1)
    return {
        "n": n,
        "unary_s": unary_s,
        "compile_s": compile_s,
        "aer_s": aer_s,
        "transpile_s": transpile_s,
        "max_diff": float(np.abs(Y_aer - Y_unary).max()),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-n", type=int, default=20, help="largest n to run (8/12/16/20)")
    parser.add_argument("--batch", type=int, default=256, help="inputs per forward pass")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=5, help="best-of repeats (unary engine)")
    parser.add_argument("--aer-threads", type=int, default=1, help="Aer max_parallel_threads")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    header = (
        f"{'n':>3} {'gates':>6} {'unary [ms]':>11} {'compile [ms]':>13} {'Aer [s]':>9} "
        f"{'transpile [s]':>14} {'Aer/unary':>10} {'max |diff|':>11}"
    )
    print(
        f"pyramid forward pass, batch {args.batch}, shared random angles, "
        f"Aer threads {args.aer_threads}"
    )
    print(header)
    print("-" * len(header))
    for n in SIZES:
        if n > args.max_n:
            continue
        row = run(n, args.batch, rng, args.repeats, args.aer_threads)
        print(
            f"{n:>3} {n * (n - 1) // 2:>6} {1e3 * row['unary_s']:>11.3f} "
            f"{1e3 * row['compile_s']:>13.2f} {row['aer_s']:>9.3f} {row['transpile_s']:>14.2f} "
            f"{row['aer_s'] / row['unary_s']:>10.0f} {row['max_diff']:>11.1e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
