"""Noisy sampling: the automatic Aer method choice (``HardwareTarget.sampler()``, what
``SamplerEngine(target=...)`` uses) against every fixed Aer method and against plain
``SamplerV2.from_backend(AerSimulator.from_backend(backend))``, all on the same transpiled
circuits (a unary loader and a round-robin sub-unitary, one PUB of ``rows`` parameter rows).

Goal (issue "Hardware as objects", item 4): the automatic choice within 10% of the best fixed
method on every cell. CPU time of the process (Aer's threads included) per call: each sampler
first runs a pilot (1 row, at most 32 shots) twice; the first pilot builds its simulators
(``setup`` column: the auto sampler's first pilot less its second), the second predicts the
cell's time (by rows x shots for trajectories, by rows for the density matrix); a sampler
predicted over ``--max-seconds`` for its ``--repeat`` runs is not run (``>N``: the prediction
in seconds per call), the others give the median of ``--repeat`` calls. The device's noise
model is built and serialised before any timing. The machine is shared: the load average is
printed per cell; read the ratios, not the seconds.

    python benchmarks/bench_noisy.py [--n 4 6 8 10 12] [--rows 1 16] [--shots 16 256 4000]
                                     [--targets heavy_hex fake_kolkata] [--repeat 3]
                                     [--cell heavy_hex 8 1 16] [--max-seconds 60]
                                     [--one-thread]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2

from qdensity.ansatze import round_robin
from qdensity.hardware.aer_sampling import DENSITY_MATRIX_MAX_QUBITS, active_qubits
from qdensity.hardware.targets import get_target
from qdensity.loaders import unary_loader_template
from qdensity.plans import measured

FIXED = ("statevector", "density_matrix", "matrix_product_state")
_PILOT_SHOTS = 32


def _cpu(run) -> float:
    t = time.process_time()
    run()
    return time.process_time() - t


def _time(make, compiled, values, shots, method, repeat, max_seconds):
    """(median CPU seconds per call or None, predicted seconds per call, set-up seconds)."""
    pilot_shots = min(shots, _PILOT_SHOTS)
    pilot = [(compiled, values[:1], pilot_shots)]
    t0 = time.process_time()
    sampler = make()
    sampler.run(pilot).result()
    first = time.process_time() - t0  # construction and first pilot
    second = _cpu(lambda: sampler.run(pilot).result())
    if method == "plain":  # Aer's automatic rule: the density matrix above 2 ** a shots
        method = "density_matrix" if shots > 2 ** active_qubits(compiled) else "statevector"
    scale = len(values) * (1 if method == "density_matrix" else shots / pilot_shots)
    predicted = second * scale
    if predicted * repeat > max_seconds:
        return None, predicted, first - second
    pub = [(compiled, values, shots)]
    runs = [_cpu(lambda: sampler.run(pub).result()) for _ in range(repeat)]
    return float(np.median(runs)), predicted, first - second


def _measure(target, compiled, n, rows, shots, a):
    values = np.random.default_rng(rows).uniform(-np.pi, np.pi, (rows, compiled.num_parameters))
    chosen = target.sampler(seed=3).choose(compiled, shots)["method"]
    kw = {"compiled": compiled, "values": values, "shots": shots, "repeat": a.repeat,
          "max_seconds": a.max_seconds}
    cell = {"auto": _time(lambda: target.sampler(seed=3), method=chosen, **kw)}
    for m in a.methods:
        if m == "density_matrix" and n > DENSITY_MATRIX_MAX_QUBITS:
            continue
        cell[m] = _time(lambda m=m: target.sampler(seed=3, method=m, options=a.fixed_options),
                        method=m, **kw)
    if not a.no_plain:
        cell["plain"] = _time(lambda: SamplerV2.from_backend(
            AerSimulator.from_backend(target.backend), seed=3), method="plain", **kw)
    return cell, chosen


def _show(cell, key) -> str:
    if key not in cell:
        return f"{'-':>8}"
    t, pred, _ = cell[key]
    if t is None:
        return f"{'>' + format(pred, '.0f'):>8}"
    return f"{t:>8.3f}" if t < 10 else f"{t:>8.1f}"


def _cells(a) -> list[tuple[str, int, int, int]]:
    if a.cell:
        return [(t, int(n), int(r), int(s)) for t, n, r, s in a.cell]
    return [(t, n, r, s) for t in a.targets for n in a.n for r in a.rows for s in a.shots]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, nargs="+", default=[4, 6, 8, 10, 12])
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 16])
    ap.add_argument("--shots", type=int, nargs="+", default=[16, 256, 4000])
    ap.add_argument("--targets", nargs="+", default=["heavy_hex", "fake_kolkata"])
    ap.add_argument("--cell", nargs=4, action="append", metavar=("TARGET", "N", "ROWS", "SHOTS"),
                    help="run only these cells (repeatable); replaces the grid")
    ap.add_argument("--methods", nargs="+", default=list(FIXED), choices=FIXED,
                    help="fixed methods to compare")
    ap.add_argument("--repeat", type=int, default=3, help="timed calls per sampler (median)")
    ap.add_argument("--max-seconds", type=float, default=60.0,
                    help="skip a sampler whose predicted repeat x per-call time exceeds this")
    ap.add_argument("--no-plain", action="store_true", help="leave out plain AerSimulator")
    ap.add_argument("--one-thread", action="store_true",
                    help="fixed methods on one thread (their default is all threads, which "
                         "costs CPU on small states; the auto sampler picks threads per PUB)")
    a = ap.parse_args()
    a.fixed_options = ({"max_parallel_threads": 1, "max_parallel_shots": 1} if a.one_thread
                       else None)
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores; median of {a.repeat}; "
          f"fixed methods on {'one thread' if a.one_thread else 'all threads'}")
    print(f"{'target':<13}{'n':>3}{'rows':>5}{'shots':>6}{'auto':>8}{'method':>8}{'setup':>7}"
          + "".join(f"{m[:6]:>8}" for m in FIXED) + f"{'plain':>8}{'auto/best':>10}"
          f"{'auto/plain':>11}{'load':>6}   (CPU seconds per call)")
    worst = 0.0
    built: dict = {}
    for name, n, rows, shots in _cells(a):
        if (name, n) not in built:
            target = get_target(name, None if name.startswith("fake_") else n, seed=1)
            circ = measured(unary_loader_template(n, parameter_prefix="x")
                            .compose(round_robin(n)))
            compiled = target.transpile(circ)
            one = np.zeros((1, compiled.num_parameters))
            target.sampler(method="statevector").run([(compiled, one, 1)]).result()  # serialise
            built = {(name, n): (target, compiled)}
        target, compiled = built[(name, n)]
        cell, chosen = _measure(target, compiled, n, rows, shots, a)
        fixed = [cell[m][0] for m in FIXED if m in cell and cell[m][0] is not None]
        t_auto = cell["auto"][0]
        best = min(fixed) if fixed else None
        r_best = t_auto / best if t_auto is not None and best else float("nan")
        plain = cell.get("plain", (None,))[0]
        r_plain = t_auto / plain if t_auto is not None and plain else float("nan")
        if r_best == r_best:
            worst = max(worst, r_best)
        print(f"{name:<13}{n:>3}{rows:>5}{shots:>6}{_show(cell, 'auto')}{chosen[:6]:>8}"
              f"{cell['auto'][2]:>7.2f}" + "".join(_show(cell, m) for m in FIXED)
              + _show(cell, "plain")
              + f"{r_best:>10.2f}{r_plain:>11.2f}{os.getloadavg()[0]:>6.1f}", flush=True)
    print(f"worst auto / best fixed (cells where both ran): {worst:.2f} (goal <= 1.10)")


if __name__ == "__main__":
    main()
