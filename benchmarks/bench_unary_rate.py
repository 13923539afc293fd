"""The unary engine against a JAX-jit peer and against ``numpy.matmul``'s arithmetic rate.

Round-robin circuits (n - 1 rounds of n / 2 disjoint RBS gates, one parameter per gate) at
n = 16, 64, 256, 1024, batch 64, angles shared by the batch:

* qdensity: ``forward(uc, X, theta)`` and ``vjp(uc, X, theta, W, reduce="sum")`` (the forward
  and reverse pass in one compiled call per block of rows), the public, checked calls;
* JAX: the peer of ``_scale_unary.jax_calls`` (each round a gather / rotate / scatter under
  ``lax.scan``, ``jax.jit``-compiled; its gradient by ``jax.grad``, also jitted);
* ``numpy.matmul`` of an (n x n) by an (n x 64) matrix on the same threads.

Flops: a rotation costs 6 per batch column (4 multiplies, 2 adds), so a forward pass is
``6 G B``; forward + gradient is ``22 G B`` (the forward rotation 6; in the reverse pass the
gate's dot product 4 and the two rotations back, of the activations and of the gradients, 12).
A matmul is ``2 n^2 B``. Rates are GFLOP/s of wall time (the best call of each callable),
every callable of a size measured in turns (interleaved) so they see the same load; run it on
quiet cores. Beside them, the same ratios per CPU-second, from each callable's CPU time summed
over all its timed calls (``time.process_time``): not from single calls, since Linux updates
another thread's CPU time at scheduler ticks, so a call of a millisecond on two threads may
read as half its CPU time (the best of such readings overstated a threaded matmul's rate
per CPU-second up to 1.8x).

Threads: ``--threads 1`` limits qdensity (``QDENSITY_NUM_THREADS``), OpenBLAS / MKL (the
matmul) and XLA (``--xla_cpu_multi_thread_eigen=false``, one intra-op thread) to one thread
each; without it each library uses its default. Without ``--threads`` the script runs itself
twice, once per setting.

    python benchmarks/bench_unary_rate.py [--sizes 16 64 256 1024] [--threads 1|default]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _limit_threads() -> None:
    """One thread everywhere; before numpy, numba and JAX are imported."""
    for var in ("QDENSITY_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[var] = "1"
    os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen"
                               "=false intra_op_parallelism_threads=1").strip()


def _measure(fns: dict, repeats: int, rounds: int = 3, window: float = 0.3) -> dict:
    """Per callable: the best wall seconds of a call, and CPU seconds per call over all timed
    calls (each round at least ``repeats`` calls and ``window`` seconds, so that the CPU sum
    spans many scheduler ticks); in turns."""
    best = {k: float("inf") for k in fns}
    cpu = {k: [0.0, 0] for k in fns}
    for _ in range(rounds):
        for key, fn in fns.items():
            time.sleep(0.2)  # XLA's threads spin a while after a call
            t = time.perf_counter()
            while time.perf_counter() - t < 0.1:  # warm-up
                fn()
            c, start, calls = time.process_time(), time.perf_counter(), 0
            while calls < repeats or time.perf_counter() - start < window:
                t = time.perf_counter()
                fn()
                best[key] = min(best[key], time.perf_counter() - t)
                calls += 1
            cpu[key][0] += time.process_time() - c
            cpu[key][1] += calls
    return {k: (best[k], cpu[k][0] / cpu[k][1]) for k in fns}


def run(sizes, batch: int = 64) -> list[dict]:
    import numpy as np

    sys.path.insert(0, HERE)
    import _scale_unary as S

    from qdensity.execution._threads import num_threads

    rows = []
    print(f"\n== unary engine vs JAX-jit and numpy.matmul: round-robin, batch {batch}; threads: "
          f"qdensity {num_threads()}, BLAS {os.environ.get('OPENBLAS_NUM_THREADS', 'default')}"
          f" ==")
    print(f"{'n':>5}{'gates':>8} | {'fwd ms':>8}{'f+g ms':>8}{'jax f':>8}{'jax g':>9}"
          f"{'jf/f':>6}{'jg/g':>6} | {'GF/s f':>7}{'GF/s g':>7}{'matmul':>7}{'f/mm':>6}"
          f"{'g/mm':>6} | {'cpu f/mm':>9}{'g/mm':>6} | {'|dgrad|':>8}{'load':>5}")
    for n in sizes:
        q = S.qdensity_calls(n, batch)
        jx = S.jax_calls(n, batch)
        rng = np.random.default_rng(1)
        M, Z = rng.normal(size=(n, n)), rng.normal(size=(n, batch))
        fns = {"f": q["forward"], "g": q["grad"], "mm": lambda M=M, Z=Z: np.matmul(M, Z)}
        if jx is not None:
            fns.update(jf=jx["forward"], jg=jx["grad"])
        t = _measure(fns, repeats=20 if n <= 64 else (7 if n <= 256 else 3))
        G = q["uc"].num_gates
        flops = {"f": 6.0 * G * batch, "g": 22.0 * G * batch, "mm": 2.0 * n * n * batch}
        wall = {k: flops[k] / t[k][0] / 1e9 for k in flops}  # GFLOP/s, best call
        per_cpu = {k: flops[k] / t[k][1] / 1e9 for k in flops}  # GFLOP/s per CPU-second
        gf, gg, gm = wall["f"], wall["g"], wall["mm"]
        cf, cg = per_cpu["f"] / per_cpu["mm"], per_cpu["g"] / per_cpu["mm"]
        row = {"n": n, "gates": G, "forward_s": t["f"][0], "grad_s": t["g"][0],
               "gflops_forward": gf, "gflops_grad": gg, "gflops_matmul": gm,
               "cpu_ratio_forward": cf, "cpu_ratio_grad": cg, "load": os.getloadavg()[0]}
        line = f"{n:>5}{G:>8} | {1e3 * t['f'][0]:>8.3f}{1e3 * t['g'][0]:>8.2f}"
        if jx is not None:
            diff = float(np.max(np.abs(np.asarray(jx["grad"]()) - q["grad"]())))
            row.update(jax_forward_s=t["jf"][0], jax_grad_s=t["jg"][0], grad_diff=diff)
            line += (f"{1e3 * t['jf'][0]:>8.3f}{1e3 * t['jg'][0]:>9.2f}"
                     f"{t['jf'][0] / t['f'][0]:>6.2f}{t['jg'][0] / t['g'][0]:>6.2f}")
        else:
            diff = float("nan")
            line += f"{'(no jax)':>37}"
        line += (f" | {gf:>7.2f}{gg:>7.2f}{gm:>7.2f}{gf / gm:>6.2f}{gg / gm:>6.2f} | "
                 f"{cf:>9.2f}{cg:>6.2f} | {diff:>8.1e}{row['load']:>5.1f}")
        print(line, flush=True)
        rows.append(row)
    print("ms: best wall time per call; jf/f, jg/g: JAX time / qdensity time (> 1: qdensity "
          "ahead); GF/s of wall time, best call (forward 6, forward + gradient 22 flops per "
          "rotation and column; matmul 2 n^2 B); f/mm, g/mm: fraction of matmul's rate; cpu: "
          "the same fractions per CPU-second over all timed calls; |dgrad|: max difference of "
          "the two gradients; load: 1-minute load average")
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[16, 64, 256, 1024])
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--threads", choices=["1", "default"])
    a = ap.parse_args(argv)
    if a.threads is None:  # both settings, each in a fresh process (thread pools are fixed)
        for setting in ("1", "default"):
            subprocess.run([sys.executable, os.path.abspath(__file__), "--threads", setting,
                            "--batch", str(a.batch), "--sizes", *map(str, a.sizes)],
                           check=True)
        return
    if a.threads == "1":
        _limit_threads()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    run(a.sizes, a.batch)


if __name__ == "__main__":
    main()
