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
import subprocess
import sys
import time

import numpy as np

from qdensity.circuits.ansatze.hamming import round_robin_pairs
from qdensity.execution.unary import UnaryCircuit, forward, vjp


def rr_gate_list(n: int) -> np.ndarray:
    return np.array([p for rnd in round_robin_pairs(n) for p in rnd], dtype=np.intp)


def _best(fn, repeats):
    best = np.inf
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


def qdensity_times(n: int, batch: int, repeats: int, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    uc = UnaryCircuit.from_gates(n, rr_gate_list(n))
    _ = uc._plan  # layers and their sparse matrices (built once per circuit)
    build = time.perf_counter() - t0
    X = rng.normal(size=(batch, n))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    theta = rng.normal(size=uc.num_parameters)
    w = rng.normal(size=n)
    Y, tf = _best(lambda: forward(uc, X, theta), repeats)
    (g, _), tg = _best(lambda: vjp(uc, X, theta, np.broadcast_to(w, (batch, n)), reduce="sum"),
                       repeats)
    return {"gates": uc.num_gates, "layers": len(uc.layers), "build_s": build,
            "forward_s": tf, "grad_s": tg, "loss": float(np.sum(Y @ w)), "grad": g}


def jax_times(n: int, batch: int, repeats: int, seed: int = 0) -> dict | None:
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
    Y, tf = _best(lambda: fwd(theta_j, X).block_until_ready(), repeats)
    g, tg = _best(lambda: grad(theta_j, X, w_j).block_until_ready(), repeats)
    return {"compile_s": compile_s, "forward_s": tf, "grad_s": tg,
            "loss": float(np.sum(np.asarray(Y) @ w)), "grad": np.asarray(g)}


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


def run(sizes=(64, 256, 1024), batch: int = 64, repeats: int = 3, old: str | None = None,
        old_max_n: int = 256) -> list[dict]:
    rows = []
    print(f"\n== unary engine: round-robin, forward + reverse gradient, batch {batch} ==")
    print(f"{'n':>5}{'gates':>9}{'layers':>7} | {'fwd s':>8}{'grad s':>8}{'GF/s f':>7}"
          f"{'GF/s g':>7} | {'jax fwd':>8}{'jax grad':>9}{'jax/qd f':>9}{'jax/qd g':>9}"
          f"{'jit s':>7} | {'old fwd':>8}{'old grad':>9}{'old/qd g':>9}{'|dgrad|':>9}")
    for n in sizes:
        qd = qdensity_times(n, batch, repeats)
        jx = jax_times(n, batch, repeats)
        od = old_times(old, n, batch) if old and n <= old_max_n else None
        flops = 6.0 * qd["gates"] * batch
        row = {"n": n, "gates": qd["gates"], "layers": qd["layers"], "build_s": qd["build_s"],
               "forward_s": qd["forward_s"], "grad_s": qd["grad_s"],
               "gflops_forward": flops / qd["forward_s"] / 1e9,
               "gflops_grad": 2 * flops / qd["grad_s"] / 1e9}
        line = (f"{n:>5}{qd['gates']:>9}{qd['layers']:>7} | {qd['forward_s']:>8.4f}"
                f"{qd['grad_s']:>8.4f}{row['gflops_forward']:>7.2f}{row['gflops_grad']:>7.2f} | ")
        if jx is not None:
            row.update(jax_forward_s=jx["forward_s"], jax_grad_s=jx["grad_s"],
                       jax_compile_s=jx["compile_s"],
                       max_abs_grad_diff_vs_jax=float(np.max(np.abs(jx["grad"] - qd["grad"]))))
            line += (f"{jx['forward_s']:>8.4f}{jx['grad_s']:>9.4f}"
                     f"{jx['forward_s'] / qd['forward_s']:>9.2f}"
                     f"{jx['grad_s'] / qd['grad_s']:>9.2f}{jx['compile_s']:>7.1f} | ")
        else:
            line += f"{'(no jax: pip install -e .[bench])':>42} | "
        if od is not None:
            row.update(old_forward_s=od["forward_s"], old_grad_s=od["grad_s"],
                       old_build_s=od["build_s"])
            line += (f"{od['forward_s']:>8.3f}{od['grad_s']:>9.3f}"
                     f"{od['grad_s'] / qd['grad_s']:>9.1f}")
        else:
            line += f"{'-':>8}{'-':>9}{'-':>9}"
        line += f"{row.get('max_abs_grad_diff_vs_jax', float('nan')):>9.1e}"
        print(line, flush=True)
        rows.append(row)
    return rows
