"""Noisy-sampling section of bench_scale.py: seconds per million shots, noiseless vs noisy.

A density round-robin model's forward plan (16 rows) on a heavy-hex target, sampled through
``SamplerEngine(target=...)``. "plain" is Aer's SamplerV2 with its automatic method and no
options; "branching" the previous default of ``target.sampler`` (``method="automatic"`` with
:data:`qdensity.hardware.aer_sampling.FAST_SAMPLER_OPTIONS` and shot branching turned back on,
for its timing only: with noise it samples wrong distributions in qiskit-aer 0.18.2); "auto"
today's default (:mod:`qdensity.hardware.aer_sampling`: the method per PUB by active qubits
and shots). Wall and CPU seconds (``getrusage``, Aer's threads included) per million shots.
Transpilation is done once in a warm-up and not timed.
"""

from __future__ import annotations

import os
import resource
import time
import warnings

import numpy as np

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.execution.samplers import target_sampler
from qdensity.hardware.targets import get_target

_KINDS = {"plain": {"method": "automatic", "fast": False},
          "branching": {"method": "automatic", "fast": True,
                        "options": {"shot_branching_enable": True}},
          "auto": {}}


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _per_million(n: int, rows: int, shots: int, noisy: bool, kind: str,
                 seed: int = 0) -> tuple[float, float]:
    target = get_target("heavy_hex", n, seed=seed, noise=noisy)
    sampler = target_sampler(target, seed=seed, **_KINDS[kind])
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       seed=seed)
    X = np.random.default_rng(seed).normal(size=(rows, n))
    plans = [model.expectation_plan(k, X, shots=shots) for k in range(model.num_subunitaries)]
    engine = SamplerEngine(sampler=sampler, target=target, seed=seed)
    for p in plans:
        p.run(engine)  # warm-up: transpile every template once
    t, c = time.perf_counter(), _cpu()
    for p in plans:
        p.run(engine)
    dt, dc = time.perf_counter() - t, _cpu() - c
    total = rows * shots * len(plans)
    return dt / total * 1e6, dc / total * 1e6


def run(n: int = 6, rows: int = 16, shots: int = 1000, kinds=("branching", "auto")) -> list[dict]:
    warnings.filterwarnings("ignore")
    print(f"\n== noisy sampling: heavy-hex, density round-robin n={n}, {rows} rows x {shots} "
          f"shots per template: seconds per million shots (load {os.getloadavg()[0]:.1f}) ==")
    print(f"{'sampler':<12}{'noiseless':>11}{'(CPU)':>8}{'noisy':>9}{'(CPU)':>8}"
          f"{'noisy/noiseless CPU':>21}")
    out = []
    for kind in kinds:
        cw, cc = _per_million(n, rows, shots, False, kind)
        nw, nc = _per_million(n, rows, shots, True, kind)
        print(f"{kind:<12}{cw:>11.2f}{cc:>8.2f}{nw:>9.2f}{nc:>8.2f}{nc / cc:>21.1f}", flush=True)
        out.append({"sampler": kind, "noiseless_s_per_Mshot": cw, "noiseless_cpu_s_per_Mshot": cc,
                    "noisy_s_per_Mshot": nw, "noisy_cpu_s_per_Mshot": nc})
    if len(out) >= 2:
        b, a = out[0], out[-1]
        print(f"{b['sampler'] + '/' + a['sampler']:<12}"
              f"{b['noiseless_s_per_Mshot'] / a['noiseless_s_per_Mshot']:>11.2f}"
              f"{b['noiseless_cpu_s_per_Mshot'] / a['noiseless_cpu_s_per_Mshot']:>8.2f}"
              f"{b['noisy_s_per_Mshot'] / a['noisy_s_per_Mshot']:>9.2f}"
              f"{b['noisy_cpu_s_per_Mshot'] / a['noisy_cpu_s_per_Mshot']:>8.2f}")
    return out
