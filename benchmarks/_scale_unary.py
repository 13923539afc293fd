"""Unary-engine section of bench_scale.py: round-robin forward + reverse gradient, batch 64.

qdensity's layered engine (gate list in, no QuantumCircuit) against

* the gate-by-gate engine it replaced (``--old PATH`` to a checkout of the previous
  ``qdensity``; run in a subprocess, only at the sizes given by ``--old-max-n``), and
* a JAX peer written for this benchmark: the same orthogonal layer in the compound-matrix
  style of QC Ware's public orthogonal-network code (each round of disjoint RBS gates is a
  gather/rotate/scatter of the unary amplitudes, the rounds run under ``lax.scan``, the whole
  forward pass ``jax.jit``-compiled and differentiated by ``jax.grad``). Compile time is
  reported apart; steady-state times are the best of ``repeats``.

A pass costs ``6 x gates x batch`` flops (4 multiplies and 2 adds per rotation and column);
the achieved rate is printed against it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.execution._threads import ENV, num_threads
from qdensity.execution.unary import UnaryCircuit, forward, vjp


def rr_gate_list(n: int) -> np.ndarray:
    return np.array([p for rnd in round_robin_pairs(n) for p in rnd], dtype=np.intp)


def _best(fn, repeats, warmup: int = 3):
    for _ in range(warmup):  # first calls run slow (caches, allocator, clock)
        fn()
    best = np.inf
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


def _interleaved(fns: dict, repeats: int, rounds: int = 3) -> dict:
    """Best wall time of each callable over ``rounds`` rounds of ``repeats`` calls, the
    callables taking turns round by round so that all see the same load (a shared box), with
    a pause of 0.3 s between them (XLA's worker threads spin a while after a call, slowing whatever
    runs next); also process CPU time / wall summed over each one's timed calls."""
    best = dict.fromkeys(fns, np.inf)
    wall, cpu = dict.fromkeys(fns, 0.0), dict.fromkeys(fns, 0.0)
    for _ in range(rounds):
        for key, fn in fns.items():
            time.sleep(0.3)
            t = time.perf_counter()
            # warm-up: >= 200 ms of calls (a core left idle in the pause runs slow at first)
            while time.perf_counter() - t < 0.2:
                fn()
            for _ in range(repeats):
                c, t = time.process_time(), time.perf_counter()
                fn()
                dt = time.perf_counter() - t
                cpu[key] += time.process_time() - c
                wall[key] += dt
                best[key] = min(best[key], dt)
    return {key: (best[key], cpu[key] / wall[key]) for key in fns}


def _single_thread(fn):
    """``fn`` with the unary engine's threads off (``QDENSITY_NUM_THREADS=1``)."""
    def call():
        old = os.environ.get(ENV)
        os.environ[ENV] = "1"
        try:
            return fn()
        finally:
            if old is None:
                del os.environ[ENV]
            else:
                os.environ[ENV] = old
    return call


def qdensity_calls(n: int, batch: int, seed: int = 0) -> dict:
    """The circuit, its build time and the timed calls: forward and reverse gradient."""
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    uc = UnaryCircuit.from_gates(n, rr_gate_list(n))
    _ = uc._plan  # layers and their sparse matrices (built once per circuit)
    build = time.perf_counter() - t0
    X = rng.normal(size=(batch, n))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    theta = rng.normal(size=uc.num_parameters)
    w = rng.normal(size=n)
    W = np.broadcast_to(w, (batch, n))
    return {"uc": uc, "build_s": build, "w": w,
            "forward": lambda: forward(uc, X, theta),
            "grad": lambda: vjp(uc, X, theta, W, reduce="sum")[0]}


def qdensity_times(n: int, batch: int, repeats: int, seed: int = 0) -> dict:
    q = qdensity_calls(n, batch, seed)
    Y, tf = _best(q["forward"], repeats)
    _, tf1 = _best(_single_thread(q["forward"]), repeats)
    g, tg = _best(q["grad"], repeats)
    uc = q["uc"]
    return {"gates": uc.num_gates, "layers": len(uc.layers), "build_s": q["build_s"],
            "forward_s": tf, "forward_1t_s": tf1, "grad_s": tg,
            "loss": float(np.sum(Y @ q["w"])), "grad": g}


def jax_calls(n: int, batch: int, seed: int = 0) -> dict | None:
    """The JAX peer's jitted forward and gradient (compiled here), or None without JAX."""
    try:
        import jax
        import jax.numpy as jnp
    except ImportError:
        return None
    jax.config.update("jax_enable_x64", True)
    rounds = round_robin_pairs(n)
    width = max(len(r) for r in rounds)
    # pad every round to the same width with a dummy (identity) rotation on an extra row
    I = np.full((len(rounds), width), n, dtype=np.int32)
    J = np.full((len(rounds), width), n, dtype=np.int32)
    P = np.full((len(rounds), width), -1, dtype=np.int32)
    k = 0
    for r, rnd in enumerate(rounds):
        for c, (a, b) in enumerate(rnd):
            I[r, c], J[r, c], P[r, c] = a, b, k
            k += 1
    num_gates = k
    I, J = jnp.asarray(I), jnp.asarray(J)
    Pm = jnp.asarray(P)

    def layer_forward(theta, X):
        angles = jnp.where(Pm >= 0, jnp.concatenate([theta, jnp.zeros(1)])[Pm], 0.0)
        Z = jnp.concatenate([X.T, jnp.zeros((1, X.shape[0]))], axis=0)  # (n + 1, B)

        def step(Z, inp):
            i, j, a = inp
            c, s = jnp.cos(a)[:, None], jnp.sin(a)[:, None]
            zi, zj = Z[i], Z[j]
            Z = Z.at[i].set(c * zi - s * zj)
            Z = Z.at[j].set(s * zi + c * zj)
            return Z, None

        Z, _ = jax.lax.scan(step, Z, (I, J, angles))
        return Z[:n].T

    fwd = jax.jit(layer_forward)

    def loss(theta, X, w):
        return jnp.sum(layer_forward(theta, X) @ w)

    grad = jax.jit(jax.grad(loss))
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(batch, n))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    theta = rng.normal(size=num_gates)
    w = rng.normal(size=n)
    X, theta_j, w_j = jnp.asarray(X), jnp.asarray(theta), jnp.asarray(w)
    t = time.perf_counter()
    fwd(theta_j, X).block_until_ready()
    grad(theta_j, X, w_j).block_until_ready()
    compile_s = time.perf_counter() - t
    return {"compile_s": compile_s, "w": w,
            "forward": lambda: fwd(theta_j, X).block_until_ready(),
            "grad": lambda: grad(theta_j, X, w_j).block_until_ready()}


def jax_times(n: int, batch: int, repeats: int, seed: int = 0) -> dict | None:
    j = jax_calls(n, batch, seed)
    if j is None:
        return None
    Y, tf = _best(j["forward"], repeats)
    g, tg = _best(j["grad"], repeats)
    return {"compile_s": j["compile_s"], "forward_s": tf, "grad_s": tg,
            "loss": float(np.sum(np.asarray(Y) @ j["w"])), "grad": np.asarray(g)}


_OLD = r"""
import json, sys, time
import numpy as np
from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.circuits.ansatze import pairs_circuit
from qdensity.execution.unary import compile_unary, forward, vjp
n, batch = int(sys.argv[1]), int(sys.argv[2])
t = time.perf_counter()
uc = compile_unary(pairs_circuit(n, round_robin_pairs(n)))
build = time.perf_counter() - t
rng = np.random.default_rng(0)
X = rng.normal(size=(batch, n)); X /= np.linalg.norm(X, axis=1, keepdims=True)
theta = rng.normal(size=uc.num_parameters); w = rng.normal(size=n)
t = time.perf_counter(); Y = forward(uc, X, theta); tf = time.perf_counter() - t
t = time.perf_counter(); vjp(uc, X, theta, np.broadcast_to(w, (batch, n)), reduce="sum")
tg = time.perf_counter() - t
print(json.dumps({"build_s": build, "forward_s": tf, "grad_s": tg,
                  "loss": float(np.sum(Y @ w))}))
"""


def old_times(path: str, n: int, batch: int) -> dict | None:
    out = subprocess.run([sys.executable, "-c", _OLD, str(n), str(batch)], capture_output=True,
                         text=True, env={"PYTHONPATH": path, "PATH": ""}, timeout=1200,
                         cwd=path)  # "python -c" puts the working directory first on sys.path
    if out.returncode:
        print(out.stderr[-2000:])
        return None
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(sizes=(64, 256, 1024), batch: int = 64, repeats: int | None = None,
        old: str | None = None, old_max_n: int = 256) -> list[dict]:
    """One row per width (times in ms); ``repeats`` per round (3 rounds) defaults to 7 up to
    n = 256, else 2."""
    rows = []
    print(f"\n== unary engine: round-robin, forward + reverse gradient, batch {batch} "
          f"(threads: {num_threads()}; 1t = QDENSITY_NUM_THREADS=1) ==")
    print(f"{'n':>5}{'gates':>8}{'lay':>5} | {'fwd 1t':>8}{'fwd':>8}{'grad':>8}{'GF/s f':>7}"
          f"{'GF/s g':>7} | {'jax fwd':>8}{'jax grad':>9}{'cpu f':>6}{'cpu g':>6}"
          f"{'j/q f1':>7}{'j/q f':>6}{'j/q g':>6}{'jit s':>6} | {'old fwd':>8}{'old grad':>9}"
          f"{'old/qd g':>9}{'|dgrad|':>9}")
    for n in sizes:
        reps = repeats or (7 if n <= 256 else 2)
        q = qdensity_calls(n, batch)
        jx = jax_calls(n, batch)
        fns = {"f1": _single_thread(q["forward"]), "f": q["forward"], "g": q["grad"]}
        if jx is not None:
            fns.update(jf=jx["forward"], jg=jx["grad"])
        t = _interleaved(fns, reps)
        od = old_times(old, n, batch) if old and n <= old_max_n else None
        uc = q["uc"]
        flops = 6.0 * uc.num_gates * batch
        row = {"n": n, "gates": uc.num_gates, "layers": len(uc.layers), "build_s": q["build_s"],
               "forward_1t_s": t["f1"][0], "forward_s": t["f"][0], "grad_s": t["g"][0],
               "gflops_forward": flops / t["f"][0] / 1e9,
               "gflops_grad": 2 * flops / t["g"][0] / 1e9, "load": os.getloadavg()[0]}
        line = (f"{n:>5}{uc.num_gates:>8}{len(uc.layers):>5} | {1e3 * t['f1'][0]:>8.3f}"
                f"{1e3 * t['f'][0]:>8.3f}{1e3 * t['g'][0]:>8.2f}{row['gflops_forward']:>7.2f}"
                f"{row['gflops_grad']:>7.2f} | ")
        if jx is not None:
            diff = np.max(np.abs(np.asarray(jx["grad"]()) - q["grad"]()))
            row.update(jax_forward_s=t["jf"][0], jax_grad_s=t["jg"][0],
                       jax_cpu_forward=t["jf"][1], jax_cpu_grad=t["jg"][1],
                       jax_compile_s=jx["compile_s"], max_abs_grad_diff_vs_jax=float(diff))
            line += (f"{1e3 * t['jf'][0]:>8.3f}{1e3 * t['jg'][0]:>9.2f}{t['jf'][1]:>6.2f}"
                     f"{t['jg'][1]:>6.2f}"
                     f"{t['jf'][0] / t['f1'][0]:>7.2f}{t['jf'][0] / t['f'][0]:>6.2f}"
                     f"{t['jg'][0] / t['g'][0]:>6.2f}{jx['compile_s']:>6.1f} | ")
        else:
            line += f"{'(no jax: pip install -e .[bench])':>59} | "
        if od is not None:
            row.update(old_forward_s=od["forward_s"], old_grad_s=od["grad_s"],
                       old_build_s=od["build_s"])
            line += (f"{1e3 * od['forward_s']:>8.1f}{1e3 * od['grad_s']:>9.1f}"
                     f"{od['grad_s'] / t['g'][0]:>9.1f}")
        else:
            line += f"{'-':>8}{'-':>9}{'-':>9}"
        line += f"{row.get('max_abs_grad_diff_vs_jax', float('nan')):>9.1e}"
        print(line + f"  (load {row['load']:.1f})", flush=True)
        rows.append(row)
    print("times in ms; cpu f / cpu g: JAX's process CPU time / wall over its timed calls "
          "(1: one core busy)")
    return rows
