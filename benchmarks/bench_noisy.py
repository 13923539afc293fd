"""Noisy sampling: the automatic Aer method choice (``HardwareTarget.sampler()``, what
``SamplerEngine(target=...)`` uses) against every fixed Aer method and against plain
``SamplerV2.from_backend(AerSimulator.from_backend(backend))``, all on the same transpiled
circuits (a unary loader and a round-robin sub-unitary, one PUB of ``rows`` parameter rows).

Goal (issue "Hardware as objects", item 4): the automatic choice within 10% of the best fixed
method on every cell. CPU time of the process (Aer's threads included) per cell, best of
``--repeat`` (the first run of a sampler builds its simulators, as in a training loop's first
step); the machine is shared, so read the ratios, not the seconds.

    python benchmarks/bench_noisy.py [--n 4 6 8 10 12] [--rows 1 16] [--shots 16 256 4000]
                                     [--targets heavy_hex fake_kolkata]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2

from qdensity.ansatze import round_robin
from qdensity.hardware.aer_sampling import DENSITY_MATRIX_MAX_QUBITS
from qdensity.hardware.targets import get_target
from qdensity.loaders import unary_loader_template
from qdensity.plans import measured

FIXED = ("statevector", "density_matrix", "matrix_product_state")


def _cpu(run, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.process_time()
        run()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, nargs="+", default=[4, 6, 8, 10, 12])
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 16])
    ap.add_argument("--shots", type=int, nargs="+", default=[16, 256, 4000])
    ap.add_argument("--targets", nargs="+", default=["heavy_hex", "fake_kolkata"])
    ap.add_argument("--methods", nargs="+", default=list(FIXED), choices=FIXED,
                    help="fixed methods to compare (noisy MPS at 1000 shots is slow)")
    ap.add_argument("--repeat", type=int, default=2,
                    help="runs per cell, best kept (the first builds each sampler's simulator)")
    a = ap.parse_args()
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores")
    head = (f"{'target':<13}{'n':>3}{'rows':>5}{'shots':>6}{'auto':>8}{'method':>8}"
            + "".join(f"{m[:6]:>8}" for m in FIXED) + f"{'plain':>8}{'auto/best':>10}"
            f"{'auto/plain':>11}")
    print(head + "   (CPU seconds)")
    worst = 0.0
    for name in a.targets:
        for n in a.n:
            target = get_target(name, None if name.startswith("fake_") else n, seed=1)
            circ = measured(unary_loader_template(n, parameter_prefix="x").compose(round_robin(n)))
            compiled = target.transpile(circ)
            _ = target.noise_model  # built once, outside every timing
            plain = SamplerV2.from_backend(AerSimulator.from_backend(target.backend), seed=3)
            for rows in a.rows:
                values = np.random.default_rng(rows).uniform(-np.pi, np.pi,
                                                             (rows, compiled.num_parameters))
                for shots in a.shots:
                    pub = [(compiled, values, shots)]
                    auto = target.sampler(seed=3)
                    chosen = auto.choose(compiled, shots)["method"]
                    t_auto = _cpu(lambda s=auto, p=pub: s.run(p).result(), a.repeat)
                    fixed = {}
                    for m in a.methods:
                        if m == "density_matrix" and n > DENSITY_MATRIX_MAX_QUBITS:
                            continue
                        s = target.sampler(seed=3, method=m)
                        fixed[m] = _cpu(lambda s=s, p=pub: s.run(p).result(), a.repeat)
                    t_plain = _cpu(lambda s=plain, p=pub: s.run(p).result(), a.repeat)
                    best = min(fixed.values())
                    worst = max(worst, t_auto / best)
                    cells = "".join(f"{fixed[m]:>8.2f}" if m in fixed else f"{'-':>8}"
                                    for m in FIXED)
                    print(f"{name:<13}{n:>3}{rows:>5}{shots:>6}{t_auto:>8.2f}{chosen[:6]:>8}"
                          f"{cells}{t_plain:>8.2f}{t_auto / best:>10.2f}"
                          f"{t_auto / t_plain:>11.2f}", flush=True)
    print(f"worst auto / best fixed: {worst:.2f} (goal <= 1.10)")


if __name__ == "__main__":
    main()
