"""Device-width section of bench_scale.py: a 64-qubit density round-robin model on a heavy-hex
target of 127 or more qubits (distance 9: 193 qubits).

Builds the model (round-robin by moments: 63 sub-unitaries), its unary loader and its
commuting-generator gradient circuits (one per sub-unitary), transpiles every distinct
template once for the target and reports resources (active qubits, two-qubit count and depth)
and the time of each stage. Then samples the widest circuits it can: statevector sampling is
refused by Aer beyond its memory, so the matrix-product-state method samples the forward and
gradient circuits (low entanglement: one RBS moment after a chain loader).
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from qiskit.quantum_info import SparsePauliOp

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments
from qdensity.ansatze import round_robin
from qdensity.execution.resources import resource_report
from qdensity.execution.targets import get_target
from qdensity.gradients import density_gradient_plan


def run(n: int = 64, device_qubits: int = 127, mps_widths=(16, 32, 64), rows: int = 4,
        shots: int = 200) -> dict:
    warnings.filterwarnings("ignore")
    print(f"\n== device widths: density round-robin n={n} on heavy-hex >= {device_qubits} "
          "qubits ==")
    t0 = time.perf_counter()
    target = get_target("heavy_hex", device_qubits, seed=0)
    t_target = time.perf_counter() - t0
    t = time.perf_counter()
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], n)
    model = DensityQNN(by_moments(round_robin(n)).sub_unitaries, encoding=Encoding.unary(n),
                       observable=obs, seed=0)
    X = np.random.default_rng(0).normal(size=(rows, n))
    plan = density_gradient_plan(model, X, method="commuting", shots=shots)
    t_build = time.perf_counter() - t
    templates = {id(j.circuit): j.circuit for j in plan.jobs}
    t = time.perf_counter()
    reports = [resource_report(c, target) for c in templates.values()]
    t_transpile = time.perf_counter() - t
    two_q = [r.two_qubit_count for r in reports]
    depth2 = [r.two_qubit_depth for r in reports]
    active = [r.num_qubits for r in reports]
    print(f"target: {target.label} ({target.num_qubits} qubits) built in {t_target:.1f} s")
    print(f"model + gradient plan ({len(plan.jobs)} jobs, {len(templates)} templates, "
          f"{plan.meta['gradient_circuits']} gradient circuits per point): {t_build:.1f} s")
    print(f"transpile + resources of every template: {t_transpile:.1f} s "
          f"({t_transpile / len(templates):.2f} s each); "
          f"total {t_target + t_build + t_transpile:.1f} s")
    print(f"per template: active qubits {min(active)}-{max(active)}, two-qubit gates "
          f"{min(two_q)}-{max(two_q)} (mean {np.mean(two_q):.0f}), two-qubit depth "
          f"{min(depth2)}-{max(depth2)}")
    out = {"n": n, "target_qubits": target.num_qubits, "templates": len(templates),
           "build_s": t_build, "transpile_s": t_transpile, "target_s": t_target,
           "two_qubit_mean": float(np.mean(two_q)), "two_qubit_depth_max": int(max(depth2))}
    print(f"{'MPS sampling':<14}{'n':>4}{'jobs':>6}{'rows':>6}{'shots':>7}{'seconds':>9}")
    for m in mps_widths:
        obs_m = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], m)
        mod = DensityQNN(by_moments(round_robin(m)).sub_unitaries[:2],
                         encoding=Encoding.unary(m), observable=obs_m, seed=0)
        Xm = np.random.default_rng(1).normal(size=(rows, m))
        p = density_gradient_plan(mod, Xm, method="commuting", shots=shots)
        sampler, transpiler = _mps_sampler()
        eng = SamplerEngine(sampler=sampler, transpiler=transpiler, seed=0)
        t = time.perf_counter()
        try:
            p.run(eng)
            dt = f"{time.perf_counter() - t:>9.1f}"
        except Exception as exc:  # report where MPS stops working
            dt = f"  failed: {type(exc).__name__}: {str(exc)[:60]}"
        print(f"{'':<14}{m:>4}{len(p.jobs):>6}{rows:>6}{shots:>7}{dt}", flush=True)
    return out


def _mps_sampler():
    from qiskit import transpile
    from qiskit_aer import AerSimulator
    from qiskit_aer.primitives import SamplerV2

    sim = AerSimulator(method="matrix_product_state", seed_simulator=0)

    def transpiler(c):
        return transpile(c, basis_gates=["cx", "u", "rz", "sx", "x", "ry", "h", "s", "sdg"],
                         optimization_level=1, seed_transpiler=0)

    return SamplerV2.from_backend(sim, seed=0), transpiler
