"""Plan build: CPU seconds to build the sampled density-gradient plan of the paper's classifier
(round-robin by layers, every sub-unitary, ``Encoding.unary(n)``,
``readout="unary_probabilities"``, 16 rows, 1000 shots; built as
``benchmarks/bench_widths.py`` builds it), without running it.

Each width runs in its own fresh process (no analysis cache, no warm imports counted). The
table splits the CPU time (``time.process_time``) into the ansatz and its decomposition
(``round_robin`` + ``by_moments``), the model, and ``density_gradient_plan``; ``total`` is all
three, the figure the goal is about. ``--equivariant`` adds the equivariant builders at
n = 64 (``equivariant_commuting`` "XX" and "YY" and ``equivariant_noncommuting``, ``independent``
on the first two, the Fig. 4 density model on the angle encoding and its forward plans).

Goals (issue "Fast by default"): the plan builds in under 0.5 s CPU at n = 32 and under 5 s at
n = 256.

``--save FILE`` writes the results as JSON; ``--baseline FILE`` adds the ratio of a saved
run's total to this run's (``before / after``: above 1 is faster now).

    python benchmarks/bench_plan_build.py [--widths 32 64 128 256] [--equivariant]
                                          [--save after.json] [--baseline before.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

GOALS = {32: 0.5, 256: 5.0}


def _classifier(n: int, rows: int, shots: int) -> dict:
    import numpy as np

    from qdensity import DensityQNN, Encoding, by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.gradients import density_gradient_plan

    t0 = time.process_time()
    subs = by_moments(round_robin(n)).sub_unitaries
    t1 = time.process_time()
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    X = np.random.default_rng(1).normal(size=(rows, n))
    t2 = time.process_time()
    plan = density_gradient_plan(model, X, method="commuting", shots=shots)
    t3 = time.process_time()
    return {"ansatz_s": t1 - t0, "model_s": t2 - t1, "plan_s": t3 - t2, "total_s": t3 - t0,
            "jobs": len(plan.jobs), "gates": sum(len(j.circuit.data) for j in plan.jobs)}


def _equivariant(n: int, rows: int, shots: int) -> dict:
    """The equivariant builders at ``n`` and the Fig. 4 "XX+YY" density model: ansatz
    ``equivariant_commuting`` ("XX" and "YY", max weight 3) and ``equivariant_noncommuting``
    (4 layers); model ``independent`` on the two commuting circuits and the model on the angle
    encoding; plan its forward expectation plans (each ``V(x) U_k``, measured in the
    observable's basis). (Its commuting gradient plan at n = 64 takes over 15 minutes.)"""
    import numpy as np

    from qdensity import DensityQNN, Encoding
    from qdensity.circuits.ansatze import (
        equivariant_commuting,
        equivariant_noncommuting,
        equivariant_observable,
    )
    from qdensity.models import independent

    t0 = time.process_time()
    xx, yy = equivariant_commuting(n, "X"), equivariant_commuting(n, "Y")
    equivariant_noncommuting(n, 4)
    t1 = time.process_time()
    subs = independent([xx, yy]).sub_unitaries
    model = DensityQNN(subs, encoding=Encoding.angle(n), observable=equivariant_observable(n),
                       seed=0)
    X = np.random.default_rng(1).normal(size=(rows, n))
    t2 = time.process_time()
    plans = [model.expectation_plan(k, X, shots=shots) for k in range(model.num_subunitaries)]
    t3 = time.process_time()
    jobs = [j for p in plans for j in p.jobs]
    return {"ansatz_s": t1 - t0, "model_s": t2 - t1, "plan_s": t3 - t2, "total_s": t3 - t0,
            "jobs": len(jobs), "gates": sum(len(j.circuit.data) for j in jobs)}


def _run_child(kind: str, n: int, rows: int, shots: int, timeout: float) -> dict:
    try:
        out = subprocess.run([sys.executable, __file__, "--child", kind, str(n), "--rows",
                              str(rows), "--shots", str(shots)], capture_output=True, text=True,
                             check=False, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"ran past {timeout:.0f} s (killed)"}
    if out.returncode:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--widths", type=int, nargs="*", default=[32, 64, 128, 256])
    ap.add_argument("--equivariant", action="store_true",
                    help="also the equivariant builders at n = 64 (ansatz: equivariant_commuting "
                         "XX and YY, equivariant_noncommuting x 4; model: independent(...) and "
                         "the model; plan: its forward expectation plans)")
    ap.add_argument("--rows", type=int, default=16)
    ap.add_argument("--shots", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=1, help="runs per case (the fastest is kept)")
    ap.add_argument("--timeout", type=float, default=900, help="seconds per case")
    ap.add_argument("--save", help="write the results to this JSON file")
    ap.add_argument("--baseline", help="a JSON file from --save: print before / after")
    ap.add_argument("--child", nargs=2, metavar=("KIND", "N"))
    a = ap.parse_args()
    if a.child:
        case = _classifier if a.child[0] == "classifier" else _equivariant
        print(json.dumps(case(int(a.child[1]), a.rows, a.shots)))
        return
    base = {}
    if a.baseline:
        with open(a.baseline) as fh:
            base = json.load(fh)
    cases = [("classifier", n) for n in a.widths] + ([("equivariant", 64)] if a.equivariant
                                                     else [])
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores; {a.rows} rows x "
          f"{a.shots} shots; CPU seconds, fastest of {a.repeat}")
    print(f"{'case':<18}{'ansatz':>8}{'model':>8}{'plan':>8}{'total':>8}{'goal':>7}"
          f"{'before':>8}{'ratio':>7}{'jobs':>6}{'gates':>9}")
    saved = {}
    for kind, n in cases:
        runs = [_run_child(kind, n, a.rows, a.shots, a.timeout) for _ in range(a.repeat)]
        ok = [r for r in runs if "error" not in r]
        name = f"{kind} n={n}"
        if not ok:
            print(f"{name:<18}  {runs[-1]['error']}")
            continue
        res = min(ok, key=lambda r: r["total_s"])
        saved[name] = res
        goal = GOALS.get(n) if kind == "classifier" else None
        before = base.get(name, {}).get("total_s")
        ratio = f"{before / res['total_s']:>7.2f}" if before else f"{'':>7}"
        print(f"{name:<18}{res['ansatz_s']:>8.2f}{res['model_s']:>8.2f}{res['plan_s']:>8.2f}"
              f"{res['total_s']:>8.2f}{(f'{goal:g}' if goal else '-'):>7}"
              f"{(f'{before:.2f}' if before else '-'):>8}{ratio}{res['jobs']:>6}"
              f"{res['gates']:>9}")
    if a.save:
        with open(a.save, "w") as fh:
            json.dump(saved, fh, indent=1)


if __name__ == "__main__":
    main()
