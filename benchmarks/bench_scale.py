"""Scale: commuting analysis, sampled estimates, device widths, unary engine, noisy sampling.

Prints every section of the "Scale" issue side by side with ratios:

1. ``qdensity table1`` at n = 4 8 16 32 64 (total seconds), and the round-robin density
   gradient plan build (by layers, 16 rows, commuting) at n = 16 32 64; with ``--old PATH``
   (a checkout of the previous ``qdensity``, e.g. ``git archive <commit> qdensity | tar -x -C
   PATH``) the old code path runs the same work at n = 16 in a subprocess for the ratio,
   otherwise the issue's measured figures (75 s, 98 s) are the reference.
2. The same plan (reading Z_0) sampled on Aer (16 rows, 1000 shots) at n = 16 20 24 with Aer's
   default method (a statevector per row) and with matrix-product states (a unary state has
   Schmidt rank <= 2 across every cut): seconds and peak RSS of a fresh process (estimates
   from bits, never 2^n).
3. A 64-qubit density model on a heavy-hex target of >= 127 qubits: build, transpile and
   resources; matrix-product-state sampling at 32, 64 and 128 qubits.
4. Unary engine, round-robin n = 64 256 1024, batch 64: forward and reverse gradient against a
   JAX-jit peer (``pip install -e ".[bench]"``) and the old engine (``--old``).
5. Noisy sampling: seconds per million shots, noiseless vs noisy, before vs after the Aer
   options.

    python benchmarks/bench_scale.py [--old /tmp/qdensity_old] [--sections 1 2 3 4 5]

The machine's load average is printed first: on a shared machine compare ratios, not seconds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

_TABLE1 = r"""
import sys, time, json
from qdensity.gradients.table1 import ANSATZE, table1
which = ANSATZE if sys.argv[1] == "all" else [a for a in ANSATZE if a != "equivariant_xx"]
sizes = [int(a) for a in sys.argv[2:]]
t = time.perf_counter(); rows = table1(sizes, which); dt = time.perf_counter() - t
print(json.dumps({"seconds": dt, "rows": len(rows)}))
"""

_PLAN = r"""
import sys, time, json, resource, warnings
warnings.filterwarnings("ignore")
import numpy as np
from qiskit.quantum_info import SparsePauliOp
from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.gradients import density_gradient_plan
n, rows, shots, sample = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] != "0"
# Z_0, not sum_i Z_i: on a unary input sum_i Z_i = n - 2 whatever theta, so its gradient is 0
obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
t = time.perf_counter()
model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                   observable=obs, seed=0)
X = np.random.default_rng(0).normal(size=(rows, n))
plan = density_gradient_plan(model, X, method="commuting", shots=shots)
build = time.perf_counter() - t
out = {"build_s": build, "circuits": plan.num_circuits}
if sample:
    sampler = None
    if sys.argv[4] == "mps":  # unary states have Schmidt rank <= 2 across every cut
        from qiskit_aer.primitives import SamplerV2
        sampler = SamplerV2(seed=0, options={"backend_options": {
            "method": "matrix_product_state"}})
    t = time.perf_counter()
    res = plan.run(SamplerEngine(sampler, seed=0, progress=False))
    out["sample_s"] = time.perf_counter() - t
    out["max_se"] = float(max(np.max(e) for e in res.jacobian_errors))
    out["max_abs_grad"] = float(max(np.max(np.abs(j)) for j in res.jacobians))
out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def _sub(code: str, args, path: str, timeout: float = 1800) -> dict | None:
    env = dict(os.environ, PYTHONPATH=path)
    try:
        # cwd = path too: "python -c" puts the working directory first on sys.path
        out = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                             text=True, env=env, timeout=timeout, cwd=path)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    if out.returncode:
        lines = out.stderr.strip().splitlines() or [f"exit status {out.returncode}"]
        return {"error": lines[-1][:160]}
    return json.loads(out.stdout.strip().splitlines()[-1])


_CLI = "import sys; from qdensity.cli import main; sys.exit(main(sys.argv[1:]))"


def _command(args, path: str, timeout: float = 900) -> dict:
    """Wall and CPU seconds of ``qdensity ARGS`` run as a new process (import included)."""
    before = os.times()
    t = time.perf_counter()
    try:
        out = subprocess.run([sys.executable, "-c", _CLI, *map(str, args)], capture_output=True,
                             text=True, env=dict(os.environ, PYTHONPATH=path), cwd=path,
                             timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    wall = time.perf_counter() - t
    after = os.times()
    if out.returncode:
        return {"error": (out.stderr.strip().splitlines() or ["failed"])[-1][:160]}
    cpu = (after.children_user - before.children_user
           + after.children_system - before.children_system)
    return {"seconds": wall, "cpu": cpu, "output": out.stdout}


def section_commuting(old: str | None) -> None:
    print("\n== 1. commuting analysis: Table 1 and the density gradient plan ==")
    args = ["table1", "--n", 4, 8, 16, 32, 64]
    new = _command(args, ROOT)
    if "error" in new:
        print(f"qdensity table1 --n 4 8 16 32 64: {new['error']}")
    else:
        line = (f"qdensity table1 --n 4 8 16 32 64 (every ansatz, a new process): "
                f"{new['seconds']:.1f} s wall, {new['cpu']:.1f} s CPU (goal < 10 s)")
        ref = _command(args, old) if old else {"error": ""}
        if "error" not in ref:
            same = "same table" if ref["output"] == new["output"] else "TABLES DIFFER"
            line += (f"; old code {ref['seconds']:.1f} s wall, {ref['cpu']:.1f} s CPU: "
                     f"{ref['seconds'] / new['seconds']:.1f}x, {same}")
        print(line, flush=True)
    new16 = _sub(_TABLE1, ["all", 4, 8, 16], ROOT)
    print(f"qdensity table1 --n 4 8 16 (rows only): {new16['seconds']:.1f} s vs 75 s (the "
          f"issue's figure): {75.0 / new16['seconds']:.0f}x", flush=True)
    print(f"{'plan build, round-robin by layers, 16 rows, sum Z':<52}{'n':>4}{'seconds':>9}"
          f"{'reference':>11}{'ratio':>8}")
    for n in (16, 32, 64):
        r = _sub(_PLAN, [n, 16, 100, 0], ROOT)
        if n == 16:
            o = _sub(_PLAN, [n, 16, 100, 0], old) if old else {"build_s": 98.0}
            refs = f"{o['build_s']:>11.1f}{o['build_s'] / r['build_s']:>8.0f}x"
            if old:
                refs += f"   (the issue's 98 s: {98.0 / r['build_s']:.0f}x)"
        else:
            refs = f"{'goal ' + ('2' if n == 32 else '10') + ' s':>11}{'':>8}"
        print(f"{'':<52}{n:>4}{r['build_s']:>9.2f}{refs}", flush=True)


def section_bits(sizes=(16, 20, 24), timeout: float = 1800) -> None:
    print("\n== 2. sampled density gradient (16 rows, 1000 shots, Aer, Z_0): estimates from "
          "bits ==")
    print(f"{'n':>4}{'method':>8}{'circuits':>10}{'build s':>9}{'sample s':>10}"
          f"{'peak RSS MB':>13}{'max s.e.':>10}{'max |grad|':>11}")
    for n in sizes:
        for method, flag in (("default", 1), ("mps", "mps")):
            r = _sub(_PLAN, [n, 16, 1000, flag], ROOT, timeout=timeout)
            if "error" in r:
                print(f"{n:>4}{method:>8}  {r['error']}", flush=True)
                continue
            print(f"{n:>4}{method:>8}{r['circuits']:>10}{r['build_s']:>9.2f}"
                  f"{r['sample_s']:>10.1f}{r['peak_rss_mb']:>13.0f}{r['max_se']:>10.3f}"
                  f"{r['max_abs_grad']:>11.3f}", flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default=None, help="path holding a previous qdensity package")
    ap.add_argument("--sections", type=int, nargs="*", default=[1, 2, 3, 4, 5])
    a = ap.parse_args(argv)
    warnings.filterwarnings("ignore")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if 1 in a.sections:
        section_commuting(a.old)
    if 2 in a.sections:
        section_bits()
    if 3 in a.sections:
        import _scale_device

        t = time.perf_counter()
        _scale_device.run(mps_widths=(32, 64, 128))
        print(f"(section 3: {time.perf_counter() - t:.0f} s)")
    if 4 in a.sections:
        import _scale_unary

        _scale_unary.run(old=a.old)
    if 5 in a.sections:
        import _scale_noise

        _scale_noise.run()


if __name__ == "__main__":
    main()
