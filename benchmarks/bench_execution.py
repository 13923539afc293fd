"""Batched plan execution against one job per parameter row, and transpiling once against
transpiling per row (docs/design.md, "The spine": one PUB per template carrying a parameter array).

    python benchmarks/bench_execution.py [--rows 500] [--n 6] [--shots 256]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from qiskit import transpile
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.loaders import unary_loader_template
from qdensity.execution.plans import measured


def main(rows: int = 500, n: int = 6, shots: int = 256, seed: int = 0) -> dict:
    circ = measured(unary_loader_template(n, parameter_prefix="φ").compose(pyramid(n)))
    values = np.random.default_rng(seed).uniform(-np.pi, np.pi, (rows, circ.num_parameters))
    backend = AerSimulator()
    sampler = SamplerV2(seed=seed)
    timings = {}

    t = time.perf_counter()
    tc = transpile(circ, backend, optimization_level=1, seed_transpiler=seed)
    t_transpile_once = time.perf_counter() - t
    t = time.perf_counter()
    sampler.run([(tc, values, shots)]).result()
    timings["one PUB, all rows (transpile once)"] = t_transpile_once + time.perf_counter() - t

    t = time.perf_counter()
    for v in values:
        sampler.run([(tc, v, shots)]).result()
    timings["one job per row (transpile once)"] = t_transpile_once + time.perf_counter() - t

    t = time.perf_counter()
    for v in values:
        bound = transpile(circ.assign_parameters(v), backend, optimization_level=1,
                          seed_transpiler=seed)
        sampler.run([(bound, None, shots)]).result()
    timings["one job per row, transpiled per row"] = time.perf_counter() - t

    ref = timings["one PUB, all rows (transpile once)"]
    print(f"{rows} parameter rows of a loader + pyramid circuit on {n} qubits, {shots} shots each")
    print(f"{'strategy':<42}{'seconds':>10}{'ratio':>8}")
    for name, sec in timings.items():
        print(f"{name:<42}{sec:>10.2f}{sec / ref:>8.1f}")
    return timings


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=500)
    ap.add_argument("--n", type=int, default=6)
    ap.add_argument("--shots", type=int, default=256)
    a = ap.parse_args()
    main(a.rows, a.n, a.shots)
