"""Noisy-sampling section of bench_scale.py: seconds per million shots, noiseless vs noisy.

A density round-robin model's forward plan (16 rows) on a heavy-hex target, sampled through
``SamplerEngine(target=...)``. "before" is Aer's SamplerV2 as the target built it; "after"
adds Aer options (:data:`qdensity.execution.targets.FAST_SAMPLER_OPTIONS`: shot branching
for noise, runtime parameter binding, parallel shots). Transpilation is done once in a warm-up
and not timed.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.ansatze import round_robin
from qdensity.execution.targets import get_target


def _per_million(n: int, rows: int, shots: int, noisy: bool, fast: bool, seed: int = 0) -> float:
    target = get_target("heavy_hex", n, seed=seed, noise=noisy)
    sampler = target.sampler(seed=seed, fast=fast)
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       seed=seed)
    X = np.random.default_rng(seed).normal(size=(rows, n))
    plans = [model.expectation_plan(k, X, shots=shots) for k in range(model.num_subunitaries)]
    engine = SamplerEngine(sampler=sampler, target=target, seed=seed)
    for p in plans:
        p.run(engine)  # warm-up: transpile every template once
    t = time.perf_counter()
    for p in plans:
        p.run(engine)
    dt = time.perf_counter() - t
    total = rows * shots * len(plans)
    return dt / total * 1e6


def run(n: int = 6, rows: int = 16, shots: int = 1000) -> list[dict]:
    warnings.filterwarnings("ignore")
    print(f"\n== noisy sampling: heavy-hex, density round-robin n={n}, {rows} rows x {shots} "
          "shots per template: seconds per million shots ==")
    print(f"{'':<12}{'noiseless':>11}{'noisy':>9}{'noisy/noiseless':>17}")
    out = []
    for fast in (False, True):
        clean = _per_million(n, rows, shots, False, fast)
        noisy = _per_million(n, rows, shots, True, fast)
        name = "after" if fast else "before"
        print(f"{name:<12}{clean:>11.2f}{noisy:>9.2f}{noisy / clean:>17.1f}", flush=True)
        out.append({"options": name, "noiseless_s_per_Mshot": clean,
                    "noisy_s_per_Mshot": noisy})
    b, a = out
    print(f"{'before/after':<12}"
          f"{b['noiseless_s_per_Mshot'] / a['noiseless_s_per_Mshot']:>11.2f}"
          f"{b['noisy_s_per_Mshot'] / a['noisy_s_per_Mshot']:>9.2f}")
    return out
