"""Shot schedulers for the randomised density QNN (Fig. 1c): variance at a fixed budget.

Sub-unitaries: K round-robin RBS circuits (paper Fig. 9d) on 4 qubits with random angles,
acting on the unary input e_0 (X on qubit 0); observable Z_0, so each shot's value is
(-1)^(bit 0). Exact per-sub-unitary outcome distributions come from ``Statevector``; the
synthetic source samples them (fast), so hundreds of repetitions are cheap. For each scheduler
the table gives the empirical variance of the estimate over repetitions, the analytical
variance, both as ratios to per-shot sampling, the mean reported standard error against the
empirical spread, and the bias in units of its standard error.

Analytical variances: per-shot ``(E[v^2] - f^2) / S``; proportional ``sum alpha_k^2 s_k^2 / n_k``
for its allocation; Neyman ``l^2 V_pilot + (1 - l)^2 V_main`` with ``l = P / S`` and V_main for
the allocation the true spreads would give (the pilot-estimated spreads scatter around them, so
this is a slight under-estimate). ``neyman_plain`` is Neyman with the pilot variances used as
they are (``prior_weight=0``): strata whose few pilot shots agree get a single main shot.

Run:  python benchmarks/bench_schedulers.py [--reps 1000] [--budget 1000] [--aer]
``--aer`` also runs a few repetitions through qiskit-aer's SamplerV2 (sampler_source) and
reports the time per estimate.
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np
from qiskit import transpile
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze.hamming import round_robin
from qdensity.execution.schedulers import (
    allocate_neyman,
    allocate_proportional,
    discrete_source,
    neyman,
    per_shot,
    per_shot_variance,
    proportional,
    sampler_source,
    stratified_variance,
)

NUM_QUBITS = 4


def subunitaries(num: int, rng: np.random.Generator, scales=None):
    """``num`` bound circuits X(0) + round_robin(4) with random angles (unmeasured).

    Angles of circuit ``k`` are uniform in ``[-pi, pi] * scales[k]`` (``scales`` default 1); a
    small scale keeps the circuit near the identity, so its Z_0 value is nearly deterministic.
    """
    scales = np.ones(num) if scales is None else np.asarray(scales, dtype=float)
    template = round_robin(NUM_QUBITS)
    out = []
    for k in range(num):
        qc = template.copy_empty_like()
        qc.x(0)
        qc.compose(template, inplace=True)
        angles = scales[k] * rng.uniform(-np.pi, np.pi, template.num_parameters)
        out.append(qc.assign_parameters(angles))
    return out


def z0_values() -> np.ndarray:
    outcomes = np.arange(2**NUM_QUBITS)
    return 1.0 - 2.0 * (outcomes & 1)


def neyman_analytic(alpha, means, variances, budget, pilot_fraction=0.2):
    m = int(np.sum(alpha > 0))
    n_pilot = min(max(round(pilot_fraction * budget), 2 * m), budget - m)
    pilot = allocate_proportional(alpha, n_pilot, minimum=2)
    main = allocate_neyman(alpha, np.sqrt(variances), budget - n_pilot)
    lam = n_pilot / budget
    return lam**2 * stratified_variance(alpha, variances, pilot) + (
        1 - lam
    ) ** 2 * stratified_variance(alpha, variances, main)


def run_example(name, alpha, circuits, budget, reps):
    probs = np.array([Statevector(qc).probabilities() for qc in circuits])
    values = z0_values()
    means = probs @ values
    variances = probs @ values**2 - means**2
    f = float(alpha @ means)
    source = discrete_source(probs, values)
    analytic = {
        "per_shot": per_shot_variance(alpha, means, variances, budget),
        "proportional": stratified_variance(alpha, variances, allocate_proportional(alpha, budget)),
        "neyman": neyman_analytic(alpha, means, variances, budget),
    }
    print(f"\n== {name}: K = {alpha.size}, S = {budget}, {reps} repetitions, f = {f:+.4f}")
    print("   alpha  = " + " ".join(f"{a:.3f}" for a in alpha))
    print("   f_k    = " + " ".join(f"{m:+.3f}" for m in means))
    print("   sigma_k= " + " ".join(f"{s:.3f}" for s in np.sqrt(variances)))
    header = (
        f"{'scheduler':<13}{'emp var':>11}{'analytic':>11}{'emp/an':>8}"
        f"{'emp/ps':>8}{'an/ps':>8}{'rmsSE/std':>10}{'bias/SE':>9}{'ms/est':>8}"
    )
    print(header)
    print("-" * len(header))
    plain = functools.partial(neyman, prior_weight=0.0)
    analytic["neyman_plain"] = analytic["neyman"]
    emp = {}
    for label, fn in (
        ("per_shot", per_shot),
        ("proportional", proportional),
        ("neyman", neyman),
        ("neyman_plain", plain),
    ):
        t0 = time.perf_counter()
        res = [fn(alpha, budget, source, seed=s) for s in range(reps)]
        ms = 1e3 * (time.perf_counter() - t0) / reps
        assert all(r.shots_used == budget for r in res)
        est = np.array([r.estimate for r in res])
        se = np.array([r.standard_error for r in res])
        v = est.var(ddof=1)
        emp[label] = v
        an = analytic[label]
        bias_z = (est.mean() - f) / (est.std(ddof=1) / np.sqrt(reps))
        print(
            f"{label:<13}{v:11.3e}{an:11.3e}{v / an:8.3f}"
            f"{v / emp.get('per_shot', v):8.3f}{an / analytic['per_shot']:8.3f}"
            f"{np.sqrt(np.mean(se**2)) / np.sqrt(v):10.3f}{bias_z:+9.2f}{ms:8.2f}"
        )
    known = allocate_neyman(alpha, np.sqrt(variances), budget)
    oracle = stratified_variance(alpha, variances, known)
    print("   neyman_plain: pilot variances used as they are (prior_weight=0)")
    print(
        f"   (Neyman with known sigma, no pilot: {oracle:.3e}, "
        f"{oracle / analytic['per_shot']:.3f} of per-shot)"
    )
    return probs, means


def run_aer(alpha, circuits, budget, reps):
    # Aer's primitives do not transpile: unroll the RBS gates once, before sampling.
    measured = transpile(
        [qc.measure_all(inplace=False) for qc in circuits],
        basis_gates=["cz", "rz", "sx", "x"],
        optimization_level=1,
    )
    source = sampler_source(measured, lambda b: 1.0 - 2.0 * (b & 1))
    z0 = SparsePauliOp("I" * (NUM_QUBITS - 1) + "Z")
    exact = float(alpha @ np.array([Statevector(qc).expectation_value(z0).real for qc in circuits]))
    print(f"   qiskit-aer SamplerV2, {reps} repetitions (exact f = {exact:+.4f}):")
    for fn in (per_shot, proportional, neyman):
        t0 = time.perf_counter()
        est = np.array([fn(alpha, budget, source, seed=s).estimate for s in range(reps)])
        ms = 1e3 * (time.perf_counter() - t0) / reps
        z = (est.mean() - exact) / (est.std(ddof=1) / np.sqrt(reps))
        print(f"   {fn.__name__:<13} mean {est.mean():+.4f}  bias/SE {z:+.2f}  {ms:7.1f} ms/est")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=1000)
    parser.add_argument("--budget", type=int, default=1000)
    parser.add_argument("--aer", action="store_true")
    parser.add_argument("--aer-reps", type=int, default=30)
    args = parser.parse_args()
    rng = np.random.default_rng(2024)
    examples = []
    for num in (4, 8):
        alpha = rng.dirichlet(np.full(num, 1.0))
        examples.append((f"round-robin x {num}", alpha, subunitaries(num, rng)))
    # half the sub-unitaries nearly deterministic: spreads differ, where Neyman pays off
    alpha = rng.dirichlet(np.full(8, 1.0))
    quiet = subunitaries(8, rng, scales=[1, 0.03, 1, 0.03, 1, 0.03, 1, 0.03])
    examples.append(("round-robin x 8, half near-identity", alpha, quiet))
    for name, alpha, circuits in examples:
        run_example(name, alpha, circuits, args.budget, args.reps)
        if args.aer:
            run_aer(alpha, circuits, args.budget, args.aer_reps)


if __name__ == "__main__":
    main()
