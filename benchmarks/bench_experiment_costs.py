"""Cost of one seed of each experiment in ``--paper`` mode, extrapolated from a short timed run.

Each experiment runs one seed at its ``--paper`` settings with its unit of work cut down (fewer
epochs, steps or trials; the table says which), timed on one thread; the cost of a whole seed is
that time times the cut (training dominates and is linear in it; data loading and model set-up
are counted in full, so the estimate errs high). The CPU time of the process is the measure
(wall time is printed beside it, with the load average: on a shared machine wall time
stretches with the load, CPU time much less).

    QDENSITY_NUM_THREADS=1 python benchmarks/bench_experiment_costs.py [NAME ...]
"""

from __future__ import annotations

import os
import sys
import time

# name -> (overrides of the --paper settings, factor to a whole seed, what was cut)
CUTS = {
    "mixing-lemma": ({}, 1.0, "nothing (a whole seed)"),
    "reuploading": ({"epochs": 10}, 30.0, "300 -> 10 epochs"),
    "orthoqnn-depth": ({"pretrain_epochs": 1, "epochs": 1}, 25.0, "25 + 25 -> 1 + 1 epochs"),
    "pyramid-shots": ({"trials": 1, "epochs": 1}, 32 * 100.0,
                      "32 trials x 100 epochs -> 1 x 1 per model"),
    "lcu-vs-single": ({"pretrain_epochs": 1, "lcu_epochs": 1, "sampled_points": 0}, 20.0,
                      "20 + 20 -> 1 + 1 epochs, no sampled check"),
    "equivariant": ({"pretrain_steps": 20, "density_steps": 20}, 50.0,
                    "1000 + 1000 -> 20 + 20 steps"),
    "moe": ({"trials": 1, "epochs": 2}, 32 * 50.0, "32 trials x 100 epochs -> 1 x 2 per model"),
}


def main(names: list[str]) -> None:
    from qdensity.experiments.registry import get_experiment

    print(f"{'experiment':<16}{'cut':<44}{'wall s':>8}{'cpu s':>8}{'x':>7}"
          f"{'cpu s / seed':>13}{'load':>7}")
    for name in names or list(CUTS):
        overrides, factor, what = CUTS[name]
        exp = get_experiment(name)
        config = {**exp.protocol.settings, **overrides}
        t, c = time.perf_counter(), time.process_time()
        exp.run_seed(dict(config), 0, False)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        load = os.getloadavg()[0]
        print(f"{name:<16}{what:<44}{wall:>8.1f}{cpu:>8.1f}{factor:>7.0f}{cpu * factor:>13.0f}"
              f"{load:>7.1f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
