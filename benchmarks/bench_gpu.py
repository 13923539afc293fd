"""The torch engines on a GPU against the same engines on the machine's CPU cores (issue 36).

Two sections, every cell timed side by side in one process:

* **unary**: the round-robin orthogonal layer (``n - 1`` rounds of ``n / 2`` RBS gates), batch
  ``--batch`` (1024), angles shared by the batch; forward and the reverse-mode gradient of
  ``sum(Y @ w)`` (``vjp(..., reduce="sum")``). Columns: qdensity's numpy/numba path on the CPU,
  the torch path on CPU torch, the torch path on the GPU (float64, and float32), and the JAX
  peer of ``benchmarks/_scale_unary.py`` (a ``jax.jit`` Givens layer under ``lax.scan``,
  differentiated by ``jax.grad``, float64) on JAX's default device.
* **adjoint**: ``AdjointEngine.value_and_gradient`` of ``<Z_0>`` for the hardware-efficient
  circuit (``ry``/``rz`` layers and a CZ chain, 2 repetitions), every parameter, batches
  ``--adjoint-batches``. Columns: the numba kernels on the CPU cores (``backend="auto"``), the
  torch backend on the CPU, and on the GPU in complex128 and complex64.

Values are compared across devices: each cell prints the largest absolute difference of the
outputs and gradients from the CPU reference (numpy/numba; where that was skipped, from the
GPU float64 column). A cell whose predicted time (the engine's last measured cell scaled by
``2**n x rows`` for the adjoint, ``gates x batch`` for the unary) exceeds ``--budget`` seconds
is skipped and marked ``skip`` (so is every cell after ``--deadline`` seconds, marked
``deadline``); a state that does not fit in a device's memory is refused by
the engine (``refused``). Times are medians of ``--repeats`` calls after one warm-up call
(GPU calls synchronised). Without CUDA the GPU columns say ``no GPU`` and the CPU columns run;
without JAX its column says so.

Run::

    python benchmarks/bench_gpu.py [--out bench_gpu.json] [--unary-widths 64,256,1024,4096]
        [--batch 1024] [--adjoint-widths 16,20,24,26,28,30] [--adjoint-batches 1,16,64]
        [--budget 20] [--repeats 5] [--deadline 480]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from functools import partial

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

try:
    import torch
except ImportError:  # pragma: no cover - the script says so and stops
    torch = None


def _cuda() -> bool:
    return torch is not None and torch.cuda.is_available()


def _sync(device) -> None:
    if device == "cuda":
        torch.cuda.synchronize()


def _median(fn, device, repeats: int, budget: float):
    """Median wall time of ``fn`` (one warm-up call first; fewer calls past ``budget``)."""
    t0 = time.perf_counter()
    out = fn()
    _sync(device)
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        if times and sum(times) + first > budget:
            break
        t = time.perf_counter()
        fn()
        _sync(device)
        times.append(time.perf_counter() - t)
    return out, float(np.median(times)) if times else first


class _Predictor:
    """Skips a cell whose time, scaled from the engine's last cell by ``cost``, is past the
    budget."""

    #: ``time.perf_counter()`` past which every cell is skipped (``--deadline``).
    deadline = float("inf")

    def __init__(self, budget: float):
        self.budget, self.last = budget, {}

    def skip(self, key: str, cost: float) -> float | None:
        if time.perf_counter() > self.deadline:
            return float("inf")
        prev = self.last.get(key)
        if prev is None:
            return None
        predicted = prev[1] * cost / prev[0]
        return predicted if predicted > self.budget else None

    def record(self, key: str, cost: float, seconds: float) -> None:
        self.last[key] = (cost, seconds)


def _np(x):
    if torch is not None and isinstance(x, torch.Tensor):
        return x.detach().cpu().double().numpy()
    return np.asarray(x, dtype=float)


def _ratio(results: dict, a: str, b: str, key: str) -> float:
    ra, rb = results.get(a, {}), results.get(b, {})
    return ra[key] / rb[key] if key in ra and key in rb else float("nan")


def _skip(seconds: float, width: int) -> str:
    text = "deadline" if seconds == float("inf") else f"skip ~{seconds:.0f}s"
    return f"{text:>{width}}"


def _diff(a, b) -> float:
    return float(max(np.abs(_np(x) - _np(y)).max() for x, y in zip(a, b, strict=True)))


# ------------------------------------------------------------------------------ unary
def _unary_calls(uc, X, theta, W, device, dtype):
    """``(device, forward, gradient)`` callables: numpy arrays for ``dtype=None``, else
    tensors on ``device``."""
    from qdensity.execution.unary import forward, vjp

    if dtype is not None:
        X, theta, W = (torch.tensor(np.array(a), dtype=dtype, device=device)
                       for a in (X, theta, W))
    return (device, partial(forward, uc, X, theta),
            lambda: vjp(uc, X, theta, W, reduce="sum")[0])


def unary_section(widths, batch, repeats, budget, gpu: bool) -> list[dict]:
    from _scale_unary import jax_calls, rr_gate_list

    from qdensity.execution.unary import UnaryCircuit

    pred = _Predictor(budget)
    rows = []
    cols = ["numpy", "torch-cpu"] + (["torch-gpu", "torch-gpu-f32"] if gpu else []) + ["jax"]
    print(f"\n## unary: round-robin layer, batch {batch}, shared angles; forward / gradient "
          "(ms, median)")
    print(f"{'n':>5} {'gates':>8} | " + " | ".join(f"{c:>19}" for c in cols)
          + f" | {'cpu/gpu f':>9} {'cpu/gpu g':>9} {'jax/gpu f':>9} {'jax/gpu g':>9} | "
          f"{'max diff':>8}")
    for n in widths:
        rng = np.random.default_rng(0)  # the JAX peer's inputs: X, theta, w in this order
        uc = UnaryCircuit.from_gates(n, rr_gate_list(n))
        X = rng.normal(size=(batch, n))
        X /= np.linalg.norm(X, axis=1, keepdims=True)
        theta = rng.normal(size=uc.num_parameters)
        w = rng.normal(size=n)
        W = np.broadcast_to(w, (batch, n))
        cost = float(uc.num_gates * batch)
        row = {"n": n, "gates": uc.num_gates, "layers": len(uc.layers), "batch": batch}
        results = {}
        devices = [("numpy", "cpu", None), ("torch-cpu", "cpu", torch.float64)]
        if gpu:
            devices += [("torch-gpu", "cuda", torch.float64), ("torch-gpu-f32", "cuda",
                                                                torch.float32)]
        calls = {name: _unary_calls(uc, X, theta, W, dev, dt) for name, dev, dt in devices}
        for name, (dev, fwd, grad) in calls.items():
            skipped = pred.skip(name, cost)
            if skipped is not None:
                results[name] = {"skipped_predicted_s": skipped}
                continue
            try:
                y, tf = _median(fwd, dev, repeats, budget)
                g, tg = _median(grad, dev, repeats, budget)
            except (RuntimeError, MemoryError, ValueError) as exc:  # out of memory, refused
                results[name] = {"failed": f"{type(exc).__name__}: {str(exc)[:300]}"}
                if gpu:
                    torch.cuda.empty_cache()
                continue
            pred.record(name, cost, tf + tg)
            results[name] = {"forward_s": tf, "grad_s": tg, "y": y, "g": g}
        skipped = pred.skip("jax", cost)
        if skipped is not None:
            results["jax"] = {"skipped_predicted_s": skipped}
        else:
            try:  # jax.grad keeps every layer's activations: it may run out of memory
                jx = jax_calls(n, batch)
                if jx is not None:
                    y, tf = _median(jx["forward"], "jax", repeats, budget)
                    g, tg = _median(jx["grad"], "jax", repeats, budget)
                    pred.record("jax", cost, tf + tg)
                    results["jax"] = {"forward_s": tf, "grad_s": tg, "y": y, "g": g,
                                      "compile_s": jx["compile_s"]}
            except Exception as exc:  # noqa: BLE001 - XLA's errors have no common public base
                results["jax"] = {"failed": f"{type(exc).__name__}: {str(exc)[:300]}"}
        ref = next((results[k] for k in ("numpy", "torch-gpu") if "y" in results.get(k, {})),
                   None)
        diffs = {k: _diff((r["y"], r["g"]), (ref["y"], ref["g"]))
                 for k, r in results.items() if "y" in r and ref is not None}
        cells = []
        for c in cols:
            r = results.get(c)
            if r is None:
                cells.append(f"{'(no jax)' if c == 'jax' else '-':>19}")
            elif "failed" in r:
                cells.append(f"{'failed':>19}")
            elif "y" not in r:
                cells.append(_skip(r["skipped_predicted_s"], 19))
            else:
                cells.append(f"{1e3 * r['forward_s']:>9.2f} {1e3 * r['grad_s']:>9.2f}")

        ratios = [_ratio(results, a, "torch-gpu", key) for a in ("numpy", "jax")
                  for key in ("forward_s", "grad_s")]
        print(f"{n:>5} {uc.num_gates:>8} | " + " | ".join(cells) + " | "
              + " ".join(f"{r:>9.2f}" for r in ratios)
              + f" | {max(diffs.values(), default=float('nan')):>8.1e}", flush=True)
        for k, r in results.items():
            if "failed" in r:
                print(f"      {k}: {r['failed']}")
        row["engines"] = {k: {kk: vv for kk, vv in r.items() if kk not in ("y", "g")}
                          for k, r in results.items()}
        row["max_abs_diff_vs_reference"] = diffs
        row["ratios"] = dict(zip(["cpu/gpu forward", "cpu/gpu grad", "jax/gpu forward",
                                  "jax/gpu grad"], ratios, strict=True))
        rows.append(row)
    print("cpu/gpu: qdensity numpy/numba on the CPU over torch on the GPU (float64); "
          "jax/gpu: the JAX peer over torch-gpu (above 1: torch-gpu is faster)")
    return rows


# ------------------------------------------------------------------------------ adjoint
def adjoint_section(widths, batches, repeats, budget, gpu: bool) -> list[dict]:
    from qdensity.circuits.ansatze import hardware_efficient
    from qdensity.execution.statevector.adjoint import AdjointEngine

    engines = {"numba-cpu": AdjointEngine(max_qubits=30),
               "torch-cpu": AdjointEngine(max_qubits=30, backend="torch")}
    if gpu:
        free = torch.cuda.mem_get_info()[0]
        for name, dt in (("gpu-c128", "complex128"), ("gpu-c64", "complex64")):
            engines[name] = AdjointEngine(max_qubits=30, backend="torch", device="cuda",
                                          dtype=dt, memory_budget=int(0.8 * free))
    pred = _Predictor(budget)
    rows = []
    print("\n## adjoint: hardware-efficient (ry, rz; cz chain; 2 reps), <Z_0>, value and "
          "gradient of every parameter (ms per call, median)")
    print(f"{'n':>3} {'rows':>4} {'P':>4} | " + " ".join(f"{k:>12}" for k in engines)
          + f" | {'cpu/c128':>8} {'cpu/c64':>8} | {'max diff':>8}")
    for n in widths:
        qc = hardware_efficient(n, 2, ("ry", "rz"))
        obs = "I" * (n - 1) + "Z"
        for B in batches:
            vals = np.random.default_rng(n * 100 + B).uniform(-np.pi, np.pi,
                                                             size=(B, qc.num_parameters))
            cost = float(2**n * B)
            res = {}
            for name, eng in engines.items():
                skipped = pred.skip(name, cost)
                if skipped is not None:
                    res[name] = {"skipped_predicted_s": skipped}
                    continue
                dev = "cuda" if name.startswith("gpu") else "cpu"
                try:
                    (v, j), t = _median(partial(eng.value_and_gradient, qc, obs, vals), dev,
                                        repeats, budget)
                except (ValueError, MemoryError, RuntimeError) as exc:  # refused / OOM
                    res[name] = {"refused": str(exc)[:300]}
                    if gpu:
                        torch.cuda.empty_cache()
                    continue
                pred.record(name, cost, t)
                res[name] = {"seconds": t, "v": v, "j": j}
            ref = next((res[k] for k in ("numba-cpu", "gpu-c128") if "v" in res.get(k, {})),
                       None)
            diffs = {k: _diff((r["v"], r["j"]), (ref["v"], ref["j"]))
                     for k, r in res.items() if "v" in r and ref is not None}
            cells = []
            for k in engines:
                r = res[k]
                cells.append(f"{1e3 * r['seconds']:>12.2f}" if "seconds" in r else
                             _skip(r["skipped_predicted_s"], 12)
                             if "skipped_predicted_s" in r else f"{'refused':>12}")
            ratios = [_ratio(res, "numba-cpu", "gpu-c128", "seconds"),
                      _ratio(res, "numba-cpu", "gpu-c64", "seconds")]
            print(f"{n:>3} {B:>4} {qc.num_parameters:>4} | " + " ".join(cells)
                  + f" | {ratios[0]:>8.2f} {ratios[1]:>8.2f} | "
                  f"{max(diffs.values(), default=float('nan')):>8.1e}", flush=True)
            for k, r in res.items():
                if "refused" in r:
                    print(f"      {k}: {r['refused']}")
            rows.append({"n": n, "rows": B, "parameters": qc.num_parameters,
                         "engines": {k: {kk: vv for kk, vv in r.items() if kk not in ("v", "j")}
                                     for k, r in res.items()},
                         "max_abs_diff_vs_reference": diffs,
                         "ratios": {"cpu/gpu c128": ratios[0], "cpu/gpu c64": ratios[1]}})
    print("cpu: the numba kernels on all CPU cores; cpu/c128, cpu/c64: its time over the GPU's "
          "(above 1: the GPU is faster); max diff against numba-cpu (else gpu-c128)")
    return rows


def _machine(gpu: bool) -> dict:
    info = {"python": platform.python_version(), "cpu_cores": os.cpu_count(),
            "platform": platform.platform(), "torch": getattr(torch, "__version__", None),
            "gpu": torch.cuda.get_device_name(0) if gpu else None,
            "cuda": torch.version.cuda if gpu else None}
    try:
        import jax

        info["jax"] = jax.__version__
        info["jax_devices"] = [str(d) for d in jax.devices()]
    except ImportError:
        info["jax"] = None
    from qdensity.execution._threads import num_threads

    info["qdensity_threads"] = num_threads()
    return info


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ints = lambda s: [int(v) for v in s.split(",") if v]  # noqa: E731
    ap.add_argument("--section", default="unary,adjoint")
    ap.add_argument("--unary-widths", type=ints, default=[64, 256, 1024, 4096])
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--adjoint-widths", type=ints, default=[16, 20, 24, 26, 28, 30])
    ap.add_argument("--adjoint-batches", type=ints, default=[1, 16, 64])
    ap.add_argument("--budget", type=float, default=20.0,
                    help="seconds a cell may take (predicted from the engine's last cell)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--deadline", type=float, default=480.0,
                    help="seconds after which the remaining cells are skipped (the JSON is "
                         "still written)")
    ap.add_argument("--out", default=None, metavar="JSON")
    args = ap.parse_args(argv)
    if torch is None:
        print("torch is not installed: pip install 'qdensity[torch]'")
        return 1
    _Predictor.deadline = time.perf_counter() + args.deadline
    gpu = _cuda()
    machine = _machine(gpu)
    print(f"machine: {machine}")
    if not gpu:
        print("GPU missing: torch.cuda.is_available() is False; running the CPU columns only")
    out = {"machine": machine, "args": vars(args), "load_start": os.getloadavg()}
    sections = args.section.split(",")
    if "unary" in sections:
        out["unary"] = unary_section(args.unary_widths, args.batch, args.repeats, args.budget,
                                     gpu)
    if "adjoint" in sections:
        out["adjoint"] = adjoint_section(args.adjoint_widths, args.adjoint_batches,
                                         args.repeats, args.budget, gpu)
    out["load_end"] = os.getloadavg()
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(out, fh, indent=1, default=float)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
