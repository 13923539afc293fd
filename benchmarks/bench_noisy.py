"""Noisy sampling: the automatic Aer method choice (``target_sampler(target)``, what
``SamplerEngine(target=...)`` uses) against every fixed Aer method and against plain
``SamplerV2.from_backend(AerSimulator.from_backend(backend))``, all on the same transpiled
circuits (a unary loader and a round-robin sub-unitary, one PUB of ``rows`` parameter rows).

Goal (issue "Hardware as objects", item 4): the automatic choice within 10% of the best fixed
method on every cell (issue 44, item 3: at least as cheap, 1x, now that few-qubit PUBs from
``exact_from(a)`` shots are drawn from their exact noisy distributions: method ``exact``,
:mod:`qdensity.execution.samplers.noisy_exact`), in CPU time of the process (Aer's threads
included) per call, the fixed methods on one thread with ``--one-thread`` (their default, all
threads, costs CPU on small states). Each sampler first runs a pilot (1 row; at most 32 shots for
trajectories, the cell's shots for the density matrix) twice: the first builds its simulators
(``setup`` column: the auto sampler's first pilot less its second), the second predicts the
cell's time (by rows x shots for trajectories, by rows for the density matrix). A sampler
predicted over ``--max-seconds`` for ``--repeat`` calls is not run (``>N``: the prediction in
seconds per call; a ratio that uses a prediction is marked ``~``). The others are called in
turn, round after round, each round starting one sampler later than the one before (so a change
of the machine's load, or a cache another sampler left cold, falls on all of them alike), for
``--repeat`` rounds; then auto and the fixed methods within 1.5x of the best one go on until
their calls took ``--min-seconds`` in all. The minimum over a sampler's calls is reported (what
the call costs, less what other processes took from it). ``auto/plain`` is given in CPU and in
wall time (plain Aer uses all threads). The device's noise model is built and serialised before
any timing. OpenMP threads wait passively (``OMP_WAIT_POLICY=PASSIVE`` unless set): by default
a threaded call's threads spin for a while after it returns, and the process CPU clock charged
that to the next call (measured: the auto sampler's 7 ms density-matrix call after plain Aer's
threaded one read 11 ms). The machine may be shared: the load average is printed per cell.

    python benchmarks/bench_noisy.py [--n 4 6 8 10 12] [--rows 1 16] [--shots 16 256 4000]
                                     [--targets heavy_hex fake_kolkata] [--repeat 3]
                                     [--cell heavy_hex 8 1 16] [--max-seconds 60]
                                     [--min-seconds 5] [--one-thread]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before qiskit_aer loads OpenMP

import numpy as np
from qiskit_aer import AerSimulator
from qiskit_aer.primitives import SamplerV2

from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.loaders import unary_loader_template
from qdensity.execution.plans import measured
from qdensity.execution.samplers import target_sampler
from qdensity.execution.samplers.noisy_exact import MAX_QUBITS, NoiseTables, exact_from, supported
from qdensity.hardware.aer_sampling import DENSITY_MATRIX_MAX_QUBITS, active_qubits
from qdensity.hardware.targets import get_target

FIXED = ("statevector", "density_matrix", "matrix_product_state")
_PILOT_SHOTS = 32
_MAX_ROUNDS = 50


def _clock(run) -> tuple[float, float]:
    """(CPU seconds of the process, wall seconds) of ``run()``."""
    t, w = time.process_time(), time.perf_counter()
    run()
    return time.process_time() - t, time.perf_counter() - w


def _prepare(make, compiled, values, shots, method):
    """(sampler, predicted CPU seconds per call, set-up seconds) after two pilots.

    ``method`` is the one the sampler runs the cell with; a density-matrix or exact pilot has
    the cell's shots (so that an automatic rule picks the same route for it; their cost per row
    does not grow with the shots), a trajectory pilot at most ``_PILOT_SHOTS``."""
    if method == "plain":  # Aer's automatic rule: the density matrix above 2 ** a shots
        method = "density_matrix" if shots > 2 ** active_qubits(compiled) else "statevector"
    per_row = method in ("density_matrix", "exact")
    pilot_shots = shots if per_row else min(shots, _PILOT_SHOTS)
    pilot = [(compiled, values[:1], pilot_shots)]
    t0 = time.process_time()
    sampler = make()
    sampler.run(pilot).result()
    first = time.process_time() - t0  # construction and first pilot
    second = _clock(lambda: sampler.run(pilot).result())[0]
    scale = len(values) * (1 if per_row else shots / pilot_shots)
    return sampler, second * scale, first - second


def _measure(target, compiled, n, rows, shots, a):
    """{sampler: (min CPU s or None, min wall s or None, predicted s, set-up s)}, auto's options."""
    values = np.random.default_rng(rows).uniform(-np.pi, np.pi, (rows, compiled.num_parameters))
    chosen = target_sampler(target, seed=3).choose(compiled, shots, rows)
    a_n = active_qubits(compiled)
    if (target.is_noisy and a_n <= MAX_QUBITS and shots >= exact_from(a_n)
            and supported(compiled, NoiseTables(target.noise_model))):
        chosen = {"method": "exact", "max_parallel_threads": 1}  # noisy_exact takes the PUB
    makers = {"auto": (lambda: target_sampler(target, seed=3), chosen["method"])}
    for m in a.methods:
        if m == "density_matrix" and n > DENSITY_MATRIX_MAX_QUBITS:
            continue
        makers[m] = (lambda m=m: target_sampler(target, seed=3, method=m,
                                                options=a.fixed_options), m)
    if not a.no_plain:
        makers["plain"] = (lambda: SamplerV2.from_backend(
            AerSimulator.from_backend(target.backend), seed=3), "plain")
    prepared = {k: _prepare(make, compiled, values, shots, m) for k, (make, m) in makers.items()}
    timed = {k: [] for k, (_, pred, _) in prepared.items() if pred * a.repeat <= a.max_seconds}
    pub = [(compiled, values, shots)]
    spent, rounds = 0.0, 0
    order = list(timed)
    while order and (rounds < a.repeat or (spent < a.min_seconds and rounds < _MAX_ROUNDS)):
        shift = rounds % len(order)
        for k in order[shift:] + order[:shift]:
            timed[k].append(_clock(lambda k=k: prepared[k][0].run(pub).result()))
        rounds += 1
        if rounds == a.repeat:  # go on with auto and the fixed methods that may be the best
            least = {k: min(c for c, _ in calls) for k, calls in timed.items()}
            best = min((v for k, v in least.items() if k in FIXED), default=0.0)
            order = [k for k in order if k == "auto" or (k in FIXED and least[k] <= 1.5 * best)]
        spent = sum(c for k in order for c, _ in timed[k])  # of the samplers going on
    cell = {}
    for k, (_, pred, setup) in prepared.items():
        calls = timed.get(k)
        cpu = min(c for c, _ in calls) if calls else None
        wall = min(w for _, w in calls) if calls else None
        cell[k] = (cpu, wall, pred, setup)
    return cell, chosen


def _ratio(cell, key, others) -> tuple[float, bool] | None:
    """``key`` over the least of ``others`` in CPU, and whether a prediction enters."""
    if key not in cell or not any(o in cell for o in others):
        return None
    value = {k: (cell[k][0], False) if cell[k][0] is not None else (cell[k][2], True)
             for k in (key, *others) if k in cell}
    best = min((value[o] for o in others if o in value), key=lambda v: v[0])
    mine = value[key]
    return mine[0] / best[0], mine[1] or best[1]


def _fmt(ratio: tuple[float, bool] | None) -> str:
    """A ratio as printed: ``-`` where none, ``~`` where a prediction enters."""
    return "-" if ratio is None else f"{'~' if ratio[1] else ''}{ratio[0]:.2f}"


def _show(cell, key) -> str:
    if key not in cell:
        return f"{'-':>8}"
    t, _, pred, _ = cell[key]
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
    ap.add_argument("--repeat", type=int, default=3, help="least rounds of timed calls")
    ap.add_argument("--min-seconds", type=float, default=5.0,
                    help="after --repeat rounds, more (up to 50) until the calls of auto and "
                         "the fixed methods within 1.5x of the best took this much CPU")
    ap.add_argument("--max-seconds", type=float, default=60.0,
                    help="skip a sampler whose predicted repeat x per-call time exceeds this")
    ap.add_argument("--no-plain", action="store_true", help="leave out plain AerSimulator")
    ap.add_argument("--one-thread", action="store_true",
                    help="fixed methods on one thread (their default is all threads, which "
                         "costs CPU on small states; the auto sampler picks threads per PUB)")
    a = ap.parse_args()
    a.fixed_options = ({"max_parallel_threads": 1, "max_parallel_shots": 1} if a.one_thread
                       else None)
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores; least of >= {a.repeat} "
          f"calls; fixed methods on {'one thread' if a.one_thread else 'all threads'}")
    print(f"{'target':<13}{'n':>3}{'rows':>5}{'shots':>6}{'auto':>8}{'method':>8}{'thr':>4}"
          f"{'setup':>7}" + "".join(f"{m[:6]:>8}" for m in FIXED) + f"{'plain':>8}"
          f"{'auto/best':>10}{'auto/plain':>11}{'(wall)':>8}{'load':>6}"
          "   (CPU seconds per call)")
    worst, worst_all = 0.0, 0.0
    built: dict = {}
    for name, n, rows, shots in _cells(a):
        if (name, n) not in built:
            target = get_target(name, None if name.startswith("fake_") else n, seed=1)
            circ = measured(unary_loader_template(n, parameter_prefix="x")
                            .compose(round_robin(n)))
            compiled = target.transpile(circ)
            one = np.zeros((1, compiled.num_parameters))
            serial = target_sampler(target, method="statevector")
            serial.run([(compiled, one, 1)]).result()  # serialise
            built = {(name, n): (target, compiled)}
        target, compiled = built[(name, n)]
        cell, chosen = _measure(target, compiled, n, rows, shots, a)
        r_best, r_plain = _ratio(cell, "auto", FIXED), _ratio(cell, "auto", ["plain"])
        walls = [cell[k][1] for k in ("auto", "plain") if k in cell]
        r_wall = (f"{walls[0] / walls[1]:.2f}" if len(walls) == 2 and None not in walls
                  else "-")
        if r_best is not None:
            worst_all = max(worst_all, r_best[0])
            if not r_best[1]:
                worst = max(worst, r_best[0])
        threads = "1" if chosen.get("max_parallel_threads") == 1 else "all"
        print(f"{name:<13}{n:>3}{rows:>5}{shots:>6}{_show(cell, 'auto')}"
              f"{chosen['method'][:6]:>8}{threads:>4}{cell['auto'][3]:>7.2f}"
              + "".join(_show(cell, m) for m in FIXED) + _show(cell, "plain")
              + f"{_fmt(r_best):>10}{_fmt(r_plain):>11}{r_wall:>8}{os.getloadavg()[0]:>6.1f}",
              flush=True)
    print(f"worst auto / best fixed: {worst:.2f} where measured, {worst_all:.2f} with "
          f"predictions (goal <= 1.10)")


if __name__ == "__main__":
    main()
