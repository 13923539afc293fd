"""Where a two-thread unary forward call spends its time, and what this machine's second core
gives: the facts behind the benchmarks page's "Two threads at n = 256" section.

Round-robin circuit at ``n`` (default 256), batch 64, angles shared by the batch, tiled gate
order (as the engine runs it once a circuit has carried a few hundred columns):

1. **Side by side.** The compiled forward kernel on one block of 32 columns, alone and in two
   threads at once (each its own block; started together at a barrier), and ``numpy.matmul``
   of an (n x n)(n x 64) product on one BLAS thread and on two (``threadpoolctl``, which
   scikit-learn brings; skipped without it).
2. **Hand-off.** How long after ``submit`` a task starts in the engine's idle pool thread.
3. **Python after a call.** The engine's set-up before its threads (the output array, the
   blocks, the tiled order, the shared sines and cosines), repeated on its own and right
   after a full forward call.
4. **One call's timeline.** The public ``forward`` with its threads, the engine's steps
   timed from inside (the argument checks done, the sines and cosines ready in each thread,
   each thread's rotations):
   microseconds from the call's start, for the fastest and the median calls.

    python benchmarks/bench_unary_threads.py [--n 256] [--calls 40]

Run it on quiet cores; the figures move with the machine's load.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def side_by_side(X, tiled, trig, reps: int = 200) -> tuple[float, list[float]]:
    """Milliseconds per kernel call on 32 columns: alone, and each of two threads at once."""
    from qdensity.execution.unary import _kernels

    outs = [np.empty_like(X) for _ in range(2)]

    def loop(k, res, barrier):
        barrier.wait()
        t = time.perf_counter()
        for _ in range(reps):
            _kernels.forward_block(X, 32 * k, 32 * k + 32, tiled, trig, outs[k])
        res[k] = 1e3 * (time.perf_counter() - t) / reps

    alone = [0.0, 0.0]
    loop(0, alone, threading.Barrier(1))
    pair = [0.0, 0.0]
    barrier = threading.Barrier(2)
    other = threading.Thread(target=loop, args=(1, pair, barrier))
    other.start()
    loop(0, pair, barrier)
    other.join()
    return alone[0], pair


def matmul_threads(n: int) -> dict[int, float] | None:
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return None
    from _scale_unary import _best  # benchmarks/ is on the path (main)

    rng = np.random.default_rng(0)
    M, Z = rng.normal(size=(n, n)), rng.normal(size=(n, 64))
    rates = {}
    for limit in (1, 2):
        with threadpool_limits(limit):
            rates[limit] = 2 * n * n * 64 / _best(lambda: M @ Z, 600)[1] / 1e9
    return rates


def hand_off(calls: int = 200) -> np.ndarray:
    """Microseconds from ``submit`` to the task's start in the engine's pool."""
    from qdensity.execution._threads import _executor

    pool = _executor(1)
    for _ in range(20):
        pool.submit(lambda: None).result()
    starts = []
    for _ in range(calls):
        box: list[float] = []
        t = time.perf_counter()
        pool.submit(lambda t=t, box=box: box.append(time.perf_counter() - t)).result()
        starts.append(1e6 * box[0])
        time.sleep(0.0005)
    return np.asarray(starts)


def set_up_after_a_call(uc, X, theta, calls: int = 200) -> tuple[float, float]:
    """Median microseconds of the engine's set-up before its threads: on its own, and right
    after a full forward call."""
    from qdensity.execution._threads import blocks
    from qdensity.execution.unary import _compiled
    from qdensity.execution.unary._tiles import tiled

    G = uc.num_gates

    def set_up():
        t = time.perf_counter()
        np.empty_like(X)
        ranges = blocks(X.shape[0], _compiled._FORWARD_WORK * G)
        compiled = tiled(uc, 8 * _compiled._width(ranges), X.shape[0])
        _compiled._trig_for(compiled, theta, ranges)
        return 1e6 * (time.perf_counter() - t)

    alone = [set_up() for _ in range(calls)]
    after = []
    for _ in range(calls):
        _compiled.forward_rows(X, uc, theta)
        after.append(set_up())
    return float(np.median(alone[20:])), float(np.median(after))


def timeline(uc, X, theta, calls: int) -> list[tuple[float, dict]]:
    """Per call: its microseconds and when the argument checks were done and, per thread, when
    its sines and cosines were ready and its rotations began and ended (from the call's
    start)."""
    from qdensity.execution import unary
    from qdensity.execution.unary import _compiled, _kernels, forward

    events: list[tuple[str, int, float]] = []
    kernel, ready = _kernels.forward_block, _compiled._SharedTrig.ready
    rows_fn = unary.forward_rows

    def timed_rows(*args):
        events.append(("checks done", threading.get_ident(), time.perf_counter()))
        return rows_fn(*args)

    def timed_kernel(*args):
        t = time.perf_counter()
        kernel(*args)
        events.append(("rotations", threading.get_ident(), t))
        events.append(("rotations end", threading.get_ident(), time.perf_counter()))

    def timed_ready(self, first):
        out = ready(self, first)
        events.append(("trig ready", threading.get_ident(), time.perf_counter()))
        return out

    _compiled._kernels.forward_block = timed_kernel
    _compiled._SharedTrig.ready = timed_ready
    unary.forward_rows = timed_rows
    try:
        for _ in range(20):
            forward(uc, X, theta)
        rows = []
        for _ in range(calls):
            events.clear()
            t = time.perf_counter()
            forward(uc, X, theta)
            total = 1e6 * (time.perf_counter() - t)
            caller = threading.get_ident()
            marks: dict = {}
            for name, ident, at in events:
                who = "caller" if ident == caller else "pool"
                marks[f"{who} {name}"] = 1e6 * (at - t)
            rows.append((total, marks))
    finally:
        _compiled._kernels.forward_block = kernel
        _compiled._SharedTrig.ready = ready
        unary.forward_rows = rows_fn
    rows.sort(key=lambda r: r[0])
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--calls", type=int, default=40)
    a = ap.parse_args(argv)
    sys.path.insert(0, HERE)
    import _scale_unary as S

    from qdensity.execution._threads import num_threads
    from qdensity.execution.unary import _kernels
    from qdensity.execution.unary._tiles import tiled

    q = S.qdensity_calls(a.n, 64)
    uc = q["uc"]
    rng = np.random.default_rng(0)
    X = rng.normal(size=(64, a.n))
    theta = rng.normal(size=uc.num_parameters)
    for _ in range(10):  # past the tiling threshold; kernels compiled
        q["forward"]()
    t = tiled(uc, 8 * 32, 64)
    trig = _kernels.trig_of(t, theta)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; n = {a.n}, "
          f"{uc.num_gates} gates, batch 64, qdensity threads {num_threads()}")

    print("\n1. side by side (ms per kernel call, 32 columns):")
    for _ in range(3):
        alone, pair = side_by_side(X, t, trig)
        print(f"   alone {alone:.3f}; two at once {pair[0]:.3f} and {pair[1]:.3f} "
              f"({alone / max(pair):.2f}x per thread)")
    rates = matmul_threads(a.n)
    if rates is None:
        print("   matmul: threadpoolctl not installed")
    else:
        print(f"   matmul GF/s: one BLAS thread {rates[1]:.1f}, two {rates[2]:.1f} "
              f"({rates[2] / rates[1]:.2f}x)")

    starts = hand_off()
    print(f"\n2. hand-off: a task starts {np.median(starts):.1f} us after submit (median of "
          f"{starts.size}; least {starts.min():.1f}, 90th percentile "
          f"{np.percentile(starts, 90):.1f})")

    alone, after = set_up_after_a_call(uc, X, theta)
    print(f"\n3. set-up before the threads: {alone:.1f} us on its own, {after:.1f} us right "
          f"after a call (medians)")

    rows = timeline(uc, X, theta, a.calls)
    print(f"\n4. one forward call (public forward, us from its start; {a.calls} calls):")
    mid = len(rows) // 2
    for label, (total, marks) in [("fastest", rows[0]), ("second", rows[1]),
                                  ("median", rows[mid]), ("median", rows[mid + 1])]:
        parts = ", ".join(f"{k} {v:.0f}" for k, v in sorted(marks.items(), key=lambda kv: kv[1]))
        print(f"   {label:>7} {total:.0f} us: {parts}")


if __name__ == "__main__":
    main()
