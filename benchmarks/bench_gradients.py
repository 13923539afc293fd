"""Full gradient of a 10-qubit round-robin OrthoQNN (45 RBS): pure circuit by parameter shift
versus its layer-by-layer density version by commuting-generator circuits (Table 1, Cor. 2).

Same shots per circuit, sampled on Aer's SamplerV2 through qdensity's SamplerEngine (one PUB per
template), timed after one warm-up run that transpiles every template (steady state, as in a
training loop). A third row differentiates the pure circuit block by block (its n - 1 moments are
commuting blocks; observable shifts, 2 circuits per earlier block and Pauli term, Cor. 2). The
peer, when qiskit-machine-learning is installed (``pip install -e ".[bench]"``), is its
``ParamShiftEstimatorGradient`` on the pure circuit with Aer's EstimatorV2.

    python benchmarks/bench_gradients.py [--n 10] [--shots 1000] [--points 16] [--observable z0]

``--observable z0`` (default) reads ``Z_0``, whose gradient is not zero (the block-by-block
gradient then needs ``2 (n - 1) - 1`` circuits). ``sum_z`` reads ``sum_i Z_i``: on a unary input
a Hamming-weight-preserving circuit keeps it at ``n - 2``, so every derivative is exactly zero and
the timing says nothing about accuracy; it is kept only to compare with older runs. Every
sampled gradient is checked in the same run against the exact one (ExactEngine): the table
prints ``max |sampled - exact| / standard error`` and the norm of the exact gradient.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from qiskit.quantum_info import SparsePauliOp

from qdensity import DensityQNN, Encoding, ExactEngine, SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.gradients import density_gradient_plan


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main(n: int = 10, shots: int = 1000, points: int = 16, seed: int = 0,
         observable: str = "z0") -> list[dict]:
    warnings.filterwarnings("ignore")
    if observable not in ("sum_z", "z0"):
        raise ValueError(f"observable must be 'sum_z' or 'z0', got {observable!r}")
    qubits = range(n) if observable == "sum_z" else [0]
    obs = SparsePauliOp.from_sparse_list([("Z", [q], 1.0) for q in qubits], n)
    enc = Encoding.unary(n)
    pure = DensityQNN([round_robin(n)], encoding=enc, observable=obs, seed=seed)
    dec = by_moments(round_robin(n))
    dens = DensityQNN(dec.sub_unitaries, encoding=enc, observable=obs)
    dens.set_params(theta=pure.theta)
    X = np.random.default_rng(seed).normal(size=(points, n))
    rows = []
    for name, model, method in (("pure, parameter shift", pure, "shift"),
                                ("density, commuting", dens, "commuting"),
                                ("pure, commuting blocks (observable shifts)", pure, "commuting")):
        plan = density_gradient_plan(model, X, method=method, shots=shots, forward=False)
        engine = SamplerEngine(seed=seed)
        plan.run(engine)  # warm-up: every template transpiled once (cached, as in training)
        engine.ledger.entries.clear()
        sampled, dt = _timed(lambda plan=plan, engine=engine: plan.run(engine))
        exact_plan = density_gradient_plan(model, X, method=method, forward=False)
        exact = exact_plan.run(ExactEngine())
        z = max(float(np.max(np.abs(s - e) / np.maximum(se, 1e-12)))
                for s, e, se in zip(sampled.jacobians, exact.jacobians,
                                    sampled.jacobian_errors, strict=True))
        norm = float(np.sqrt(sum(np.sum(e**2) for e in exact.jacobians)))
        rows.append({"method": name, "circuits_per_point": plan.meta["gradient_circuits"],
                     "shots": engine.ledger.total_shots, "seconds": dt / points,
                     "max_z": z, "exact_norm": norm})
    try:
        from qiskit_aer.primitives import EstimatorV2
        from qiskit_machine_learning.gradients import ParamShiftEstimatorGradient
    except ImportError:
        rows.append({"method": "qiskit-machine-learning (not installed)",
                     "circuits_per_point": None, "shots": None, "seconds": None})
    else:
        from qiskit import transpile
        from qiskit_aer import AerSimulator

        circ = transpile(pure.circuit(0), AerSimulator(), optimization_level=1)
        vals = pure.rows(0, X)
        cols = [list(pure.circuit(0).parameters).index(p) for p in circ.parameters]
        estimator = EstimatorV2(options={"default_precision": 1 / np.sqrt(shots),
                                         "run_options": {"seed": seed}})
        grad = ParamShiftEstimatorGradient(estimator)
        params = [p for p in circ.parameters if p.name.startswith("θ")]

        def job_fn():
            return grad.run([circ] * points, [obs.apply_layout(circ.layout)] * points,
                            [v[cols] for v in vals], parameters=[params] * points).result()

        job_fn()  # warm-up, as for qdensity's engines
        _, dt = _timed(job_fn)
        occ = 2 * 2 * len(params)  # 2 shifts x (rxx + ryy) per RBS
        rows.append({"method": "qiskit-ml ParamShiftEstimatorGradient (pure)",
                     "circuits_per_point": occ, "shots": occ * shots * points,
                     "seconds": dt / points})
    ref = rows[1]["seconds"]
    print(f"gradient of a {n}-qubit round-robin OrthoQNN ({n * (n - 1) // 2} RBS), "
          f"observable {observable}, {shots} shots per circuit, per data point (mean of {points})")
    print(f"{'method':<48}{'circuits':>10}{'shots':>12}{'seconds':>10}{'time / density':>16}"
          f"{'max|d|/se':>11}{'|exact|':>9}")
    for r in rows:
        if r["seconds"] is None:
            print(f"{r['method']:<48}{'-':>10}{'-':>12}{'-':>10}{'-':>16}")
            continue
        shots_pp = r["shots"] // points
        check = (f"{r['max_z']:>11.2f}{r['exact_norm']:>9.3f}" if "max_z" in r else "")
        print(f"{r['method']:<48}{r['circuits_per_point']:>10}{shots_pp:>12}"
              f"{r['seconds']:>10.3f}{r['seconds'] / ref:>16.1f}{check}")
    return rows


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10)
    ap.add_argument("--shots", type=int, default=1000)
    ap.add_argument("--points", type=int, default=16)
    ap.add_argument("--observable", choices=["sum_z", "z0"], default="z0")
    a = ap.parse_args()
    main(a.n, a.shots, a.points, observable=a.observable)
