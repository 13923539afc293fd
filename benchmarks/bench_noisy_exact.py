"""The exact noisy distribution against Aer's fixed methods, per parameter row, by width.

For each width ``n`` a unary loader and a round-robin sub-unitary are transpiled for the
seeded noisy heavy-hex device (``get_target("heavy_hex", n, seed=0)``) and one PUB of one
parameter row at ``--shots`` shots is sampled by :class:`~qdensity.execution.samplers.noisy_exact.
ExactNoisySampler` (the exact distribution, then draws) and by Aer's ``statevector``
(trajectories) and ``density_matrix`` methods on one thread. CPU seconds per call (the least
of ``--repeat`` calls after a warm-up call), with the active qubits, the exact program's fused
blocks and the circuit's instructions. This measures the crossover
:func:`~qdensity.execution.samplers.noisy_exact.exact_from` encodes (the default sampler takes
the exact route from that many shots a row).

    python benchmarks/bench_noisy_exact.py [--n 4 6 7 8 9] [--shots 16] [--repeat 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.loaders import unary_loader_template
from qdensity.execution.plans import measured
from qdensity.execution.samplers import target_sampler
from qdensity.execution.samplers.noisy_exact import ExactNoisySampler, exact_from
from qdensity.hardware.aer_sampling import active_qubits
from qdensity.hardware.targets import get_target


def _cpu(sampler, pub, repeat: int) -> float:
    sampler.run(pub).result()  # warm-up: compilation, simulators, served noise
    best = float("inf")
    for _ in range(repeat):
        t = time.process_time()
        sampler.run(pub).result()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[4, 6, 7, 8, 9])
    ap.add_argument("--shots", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    print(f"{'n':>3}{'active':>7}{'blocks':>7}{'instr':>7}{'exact':>9}{'statev':>9}"
          f"{'densit':>9}{'exact_from':>11}   (CPU s per call, 1 row, {a.shots} shots)")
    for n in a.n:
        target = get_target("heavy_hex", n, seed=0)
        compiled = target.transpile(measured(unary_loader_template(n).compose(round_robin(n))))
        row = np.random.default_rng(0).uniform(-np.pi, np.pi, (1, compiled.num_parameters))
        pub = [(compiled, row, a.shots)]
        exact = ExactNoisySampler(target.noise_model, seed=1)
        times = [_cpu(exact, pub, a.repeat)]
        for method in ("statevector", "density_matrix"):
            aer = target_sampler(target, seed=3, method=method,
                                 options={"max_parallel_threads": 1, "max_parallel_shots": 1})
            times.append(_cpu(aer, pub, a.repeat))
        active = active_qubits(compiled)
        print(f"{n:>3}{active:>7}{len(exact.program(compiled).blocks):>7}{len(compiled.data):>7}"
              + "".join(f"{t:>9.4f}" for t in times) + f"{exact_from(active):>11}", flush=True)


if __name__ == "__main__":
    main()
