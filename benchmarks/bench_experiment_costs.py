"""Cost of one seed of each experiment in ``--paper`` mode, extrapolated from a short timed run.

Each experiment runs one seed at its ``--paper`` settings with its unit of work cut down (fewer
epochs, steps or trials; the table says which), timed on one thread; the cost of a whole seed is
that time times the cut (training dominates and is linear in it; data loading and model set-up
are counted in full, so the estimate errs high). The CPU time of the process is the measure
(wall time is printed beside it, with the load average: on a shared machine wall time
stretches with the load, CPU time much less).

    QDENSITY_NUM_THREADS=1 python benchmarks/bench_experiment_costs.py [NAME ...]

``--units lcu-vs-single`` times the units of its ``--paper`` sweep instead: one trial of each
model with the epochs cut to 1 + 1 at the two ends of the paper's batch range (the trial's cost
depends on its sampled batch size), the set-up of a unit (data, split), and the LCU unit's
sampled gate-level check; a unit is set-up + 32 trials (x 20 for the epochs) + the check.

    QDENSITY_NUM_THREADS=1 python benchmarks/bench_experiment_costs.py --units lcu-vs-single

``--full noise`` times one seed of ``noise --full`` (which has no ``--paper`` mode) at two cut
training budgets and extrapolates linearly to the full budget: a seed's evaluation, ceiling
training and calibration do not grow with the budget, so one cut times a factor would not do.

    QDENSITY_NUM_THREADS=1 python benchmarks/bench_experiment_costs.py --full noise
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
    "lcu-vs-single": ({"trials": 1, "pretrain_epochs": 1, "lcu_epochs": 1, "sampled_points": 0},
                      32 * 20.0, "32 trials x (20 + 20) -> 1 x (1 + 1), no sampled check"),
    "equivariant": ({"pretrain_steps": 20, "density_steps": 20}, 50.0,
                    "1000 + 1000 -> 20 + 20 steps"),
    "moe": ({"trials": 1, "epochs": 2}, 32 * 50.0, "32 trials x 100 epochs -> 1 x 2 per model"),
}


def main(names: list[str]) -> None:
    from qdensity_paper.registry import get_experiment

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


def lcu_units(batches=(32, 256)) -> None:
    """The units of ``lcu-vs-single --paper``: CPU seconds of a unit's set-up, of one trial per
    model and batch size (epochs cut to 1 + 1), of the sampled check, and a unit's estimate."""
    import numpy as np
    from sklearn.model_selection import train_test_split

    from qdensity_paper import lcu_vs_single as lv
    from qdensity_paper.registry import get_experiment

    cfg = {**get_experiment("lcu-vs-single").protocol.settings, "pretrain_epochs": 1,
           "lcu_epochs": 1}
    factor, trials = 20.0, int(cfg["trials"])
    c = time.process_time()
    X_tr, X_te, y_tr, y_te = lv.load_data(cfg["num_qubits"], cfg["train_size"],
                                          cfg["test_size"], 0, cfg["dataset"], cfg["mnist_dir"])
    X_tr, X_va, y_tr, y_va = train_test_split(X_tr, y_tr, test_size=cfg["validation_fraction"],
                                              random_state=0, stratify=y_tr)
    setup = time.process_time() - c
    rows = (X_tr, y_tr, X_va, y_va, X_te, y_te)
    print(f"set-up (data, PCA, split; {len(y_tr)} train rows): {setup:.1f} cpu s")
    print(f"{'unit':<8}{'batch':>6}{'wall s':>8}{'cpu s':>8}{'x':>6}{'cpu s / trial':>14}"
          f"{'cpu min / unit':>15}{'load':>7}")
    for name in lv.MODEL_NAMES:
        for b in batches:
            params = {"batch_size": b, "learning_rate": 1e-3, "optimizer": "adam", "l2": 0.0}
            t, c = time.perf_counter(), time.process_time()
            lv._trial(name, params, rows, cfg, np.random.default_rng(0))
            wall, cpu = time.perf_counter() - t, time.process_time() - c
            print(f"{name:<8}{b:>6}{wall:>8.1f}{cpu:>8.1f}{factor:>6.0f}{cpu * factor:>14.0f}"
                  f"{(setup + trials * cpu * factor) / 60:>15.1f}{os.getloadavg()[0]:>7.1f}",
                  flush=True)
    t, c = time.perf_counter(), time.process_time()
    lv._sampled_check(lv._lcu_model(cfg["num_qubits"]), X_te, y_te, cfg, 0)
    print(f"sampled check ({cfg['sampled_points']} points x {cfg['sample_shots']} shots, "
          f"lcu unit only): {time.perf_counter() - t:.1f} wall s, "
          f"{time.process_time() - c:.1f} cpu s, load {os.getloadavg()[0]:.1f}")


def noise_full(budgets=(30_000, 90_000)) -> None:
    """One seed of ``noise --full`` at two training budgets; the full budget's CPU seconds from
    the line through them (cost = fixed + per shot x budget)."""
    from qdensity_paper.registry import get_experiment

    exp = get_experiment("noise")
    full, cpus = int(exp.full["budget"]), []
    for b in budgets:
        t, c = time.perf_counter(), time.process_time()
        exp.run_seed({**exp.full, "budget": int(b)}, 0, False)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        cpus.append(cpu)
        print(f"noise --full, budget {b}: {wall:.1f} wall s, {cpu:.1f} cpu s, "
              f"load {os.getloadavg()[0]:.1f}", flush=True)
    per_shot = (cpus[1] - cpus[0]) / (budgets[1] - budgets[0])
    fixed = cpus[0] - per_shot * budgets[0]
    seed = fixed + per_shot * full
    seeds = int(exp.seeds["full"])
    print(f"fixed {fixed:.0f} cpu s + {per_shot * 1e3:.2f} cpu s per 1000 training shots: "
          f"{seed:.0f} cpu s per seed at budget {full}, {seeds * seed / 60:.0f} cpu min for "
          f"its {seeds} seeds")


if __name__ == "__main__":
    if sys.argv[1:] == ["--full", "noise"]:
        noise_full()
    elif sys.argv[1:2] == ["--units"]:
        if sys.argv[2:] != ["lcu-vs-single"]:
            raise SystemExit("--units takes lcu-vs-single")
        lcu_units()
    else:
        main(sys.argv[1:])
