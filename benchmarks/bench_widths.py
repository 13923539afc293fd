"""Device widths: the sampled density gradient with the paper's classifier readout
(``readout="unary_probabilities"``, round-robin by layers, 16 rows, 1000 shots) at widths a
statevector cannot hold, through ``SamplerEngine`` with no sampler given (the engine's Aer
sampler picks matrix-product states for Hamming-weight-1 circuits).

Each case runs in its own process; the table gives its CPU time (user + system, children
included) and peak resident memory; max |z| compares the sampled outputs with the exact
unary probabilities (binomial errors of the exact values). Goals (issue "Hardware as
objects", item 3): noiseless n = 32 under 60 s CPU and 1 GB; n = 64 reported; noisy on a
127-qubit snapshot at n = 32 reported.

    python benchmarks/bench_widths.py [--widths 32 64] [--noisy fake_kyiv] [--sub 2]
                                      [--timeout 1800]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time


def _case(n: int, target: str | None, sub: int, rows: int, shots: int) -> dict:
    import numpy as np

    from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
    from qdensity.ansatze import round_robin
    from qdensity.gradients import density_gradient_plan

    subs = by_moments(round_robin(n)).sub_unitaries[:sub]
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    X = np.random.default_rng(1).normal(size=(rows, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=shots)
    engine = SamplerEngine(target=target, seed=0, progress=False)
    t = time.perf_counter()
    grad = plan.run(engine)
    wall = time.perf_counter() - t
    exact = model.expert_outputs(X, method="unary")  # (rows, K, n) exact unary probabilities
    # z-scores against the binomial error of the exact probabilities (floor 1 / shots)
    se = np.sqrt(np.maximum(exact * (1 - exact), 1.0 / shots) / shots)
    err = float(np.max(np.abs(grad.outputs - exact) / se))
    return {"wall_s": wall, "circuits": engine.ledger.total_circuits,
            "shots": engine.ledger.total_shots, "max_z": err}


def _run_child(args: list[str], timeout: float) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        out = subprocess.run([sys.executable, __file__, "--child", *args], capture_output=True,
                             text=True, check=False, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"ran past {timeout:.0f} s (killed)"}
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    res["peak_mb"] = after.ru_maxrss / 1024  # Linux: kilobytes; max over children so far
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--widths", type=int, nargs="*", default=[32, 64],
                    help="noiseless widths (none: only the noisy case)")
    ap.add_argument("--noisy", default="fake_kyiv", help="127-qubit snapshot for n = 32, or ''")
    ap.add_argument("--sub", type=int, default=2, help="sub-unitaries (layers) kept")
    ap.add_argument("--rows", type=int, default=16)
    ap.add_argument("--shots", type=int, default=1000)
    ap.add_argument("--timeout", type=float, default=1800, help="seconds per case")
    ap.add_argument("--child", nargs=2, metavar=("N", "TARGET"))
    a = ap.parse_args()
    if a.child:
        n, target = int(a.child[0]), (a.child[1] if a.child[1] != "-" else None)
        print(json.dumps(_case(n, target, a.sub, a.rows, a.shots)))
        return
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores")
    print(f"{'case':<26}{'cpu s':>8}{'wall s':>8}{'peak MB':>9}{'circuits':>10}{'shots':>10}"
          f"{'max |z|':>9}")
    cases = [(n, "-") for n in a.widths] + ([(32, a.noisy)] if a.noisy else [])
    for n, target in cases:
        res = _run_child([str(n), target, "--sub", str(a.sub), "--rows", str(a.rows),
                          "--shots", str(a.shots)], a.timeout)
        name = f"n={n} {'noiseless' if target == '-' else target}"
        if "error" in res:
            print(f"{name:<26}  {res['error']}")
            continue
        print(f"{name:<26}{res['cpu_s']:>8.1f}{res['wall_s']:>8.1f}{res['peak_mb']:>9.0f}"
              f"{res['circuits']:>10}{res['shots']:>10}{res['max_z']:>9.2f}")


if __name__ == "__main__":
    main()
