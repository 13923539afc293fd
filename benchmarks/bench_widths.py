"""Device widths: the sampled density gradient of the paper's classifier (round-robin by
layers, every sub-unitary, ``readout="unary_probabilities"``, 16 rows, 1000 shots) through
``SamplerEngine`` with no sampler given, at widths a statevector cannot hold.

The engine samples these Hamming-weight-1 templates exactly in their ``n``-dimensional
subspace (``HammingWeightSampler``) unless ``--hamming never`` sends them to Aer (matrix-product
states from 14 qubits). Each case runs in its own process. CPU seconds (user + system, all
threads): ``total`` is the whole process (interpreter, imports, work and the exact check that
follows it), ``result`` the process until the gradient is in hand (= ``import`` + ``work``),
``import`` the interpreter start and imports, ``work`` = ``build`` (the gradient plan) +
``sample`` (``engine.run``) + ``post`` (``plan.postprocess``); then peak resident memory up
to the gradient (``res MB``) and of the whole process, exact check included (``peak MB``; the
plan, its results and the engine are dropped first: the check needs the gradient alone); max |z|
compares the sampled outputs with the exact unary probabilities (binomial errors of the exact
values, floor ``1 / shots``: a rough scale, heavy-tailed where ``shots x p`` is near 1, as at
``n = 1024``); ``Bonf. p`` is the calibrated check: every output is a count of ``shots``
binomial draws, and the smallest two-sided binomial tail probability over all outputs, times
their number (Bonferroni), is at least 0.01 when the sampled outputs agree with the exact ones
at the 1% level. A readout-noisy case runs on the ``ideal`` target with a
symmetric readout error (``--readout``), which the sampler applies to the drawn bits.

Goals (issue "Fast by default"): n = 32 under 2 s CPU, n = 128 under 15 s, n = 256 under 60 s,
each under 1 GB; n = 1024 reported; also with a readout-noisy target.

``--jacobian auto`` (the default here) calls ``density_gradient_plan(model, X, method=
"commuting", shots=...)`` with no layout argument, as a user does: the plan keeps dense
Jacobians while they would hold at most 64 MiB and builds ``scipy.sparse.csr_array``
``(B * n, P_k)`` from the estimated entries alone above that (from n = 128 here). A unary output
of a round-robin moment depends on one parameter, so the dense ``(B, n, P_k)`` layout is almost
all zeros: 2.1 GB of a 3.8 GB peak at n = 256 (16 rows), 137 GB at n = 1024.
``--jacobian dense`` / ``sparse`` force a layout.

``--sampler-only`` skips the gradient plan and its post-processing: it builds the plan's kind
of templates directly (loader + sub-unitary, and the same with an RBS(pi/4) layer on the
sub-unitary's pairs: two per sub-unitary, random parameter rows) and times their sampling
alone, to measure the sampler at widths where the plan takes long to build.

    python benchmarks/bench_widths.py [--widths 32 128 256 1024] [--noisy-widths 32 256]
                                      [--readout 0.02] [--hamming auto] [--sampler-only]
                                      [--jacobian auto]
                                      [--timeout 1800]
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import resource
import subprocess
import sys
import time


def _readout_target(n: int, p: float):
    from qiskit.transpiler import Target
    from qiskit_aer.noise import NoiseModel, ReadoutError

    from qdensity import get_target

    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - p, p], [p, 1 - p]]))
    device = Target.from_configuration(["cz", "rz", "sx", "x", "measure"], num_qubits=n)
    return get_target(device, seed=0, noise_model=noise)


def _subs(n: int, sub: int, direct: bool) -> list:
    """The round-robin moments (the first ``sub`` of them when ``sub``): ``by_moments`` of
    the whole circuit, or (``direct``) each round of pairs built as its own circuit, which
    does not build the ``n (n - 1) / 2``-gate circuit first (at n = 1024 that circuit and its
    decomposition take more memory than the benchmark machine has)."""
    from qdensity import by_moments
    from qdensity.circuits.ansatze import round_robin
    from qdensity.circuits.ansatze.hamming import pairs_circuit, round_robin_pairs

    if direct:
        rounds = round_robin_pairs(n)
        rounds = rounds[:sub] if sub else rounds
        return [pairs_circuit(n, [pairs], parameter_prefix=f"θ{k}", name=f"moment_{k}")
                for k, pairs in enumerate(rounds)]
    subs = by_moments(round_robin(n)).sub_unitaries
    return subs[:sub] if sub else subs


def _exact_outputs(model, X):
    """``model.expert_outputs(X, method="unary")`` one sub-unitary at a time: each compiled
    for the unary engine and dropped (the model's own keeps all K compiled circuits, 2.5 GB
    at n = 1024), so the check costs little beside the gradient. (rows, K, n)."""
    import numpy as np

    from qdensity.execution.unary import compile_unary, forward

    Xn = X / np.linalg.norm(X, axis=1, keepdims=True)
    return np.stack([forward(compile_unary(sub), Xn,
                             model.theta[model.subunitary_parameter_indices(k)]) ** 2
                     for k, sub in enumerate(model.sub_unitaries)], axis=1)


def _case(n: int, readout: float, sub: int, rows: int, shots: int, hamming: str,
          direct: bool = False, jacobian: str = "auto") -> dict:
    import numpy as np

    from qdensity import DensityQNN, Encoding, SamplerEngine
    from qdensity.gradients import density_gradient_plan

    t0 = time.process_time()  # CPU of this process so far: interpreter start and imports
    subs = _subs(n, sub, direct)
    model = DensityQNN(subs, encoding=Encoding.unary(n), readout="unary_probabilities", seed=0)
    X = np.random.default_rng(1).normal(size=(rows, n))
    layout = {} if jacobian == "auto" else {"jacobian": jacobian}  # auto: the plain call
    plan = density_gradient_plan(model, X, method="commuting", shots=shots, **layout)
    t1 = time.process_time()
    target = _readout_target(n, readout) if readout else None
    engine = SamplerEngine(target=target, seed=0, progress=False, hamming_weight=hamming)
    results = engine.run(plan.jobs)
    t2 = time.process_time()
    grad = plan.postprocess(results)
    t3 = time.process_time()
    result_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # before the check
    samplers = sorted({e.sampler for e in engine.ledger.entries})
    circuits, shots_spent = engine.ledger.total_circuits, engine.ledger.total_shots
    del plan, results, engine  # the check needs the gradient alone
    gc.collect()
    exact = _exact_outputs(model, X)  # (rows, K, n) exact unary probabilities
    if readout:  # outcome e_j read as itself, or e_i (i != j) with both bits flipped
        q = readout
        exact = (1 - q) ** n * exact + q**2 * (1 - q) ** (n - 2) * (1 - exact)
    se = np.sqrt(np.maximum(exact * (1 - exact), 1.0 / shots) / shots)
    err = float(np.max(np.abs(grad.outputs - exact) / se))
    # calibrated: each output is a count of `shots` binomial draws; the smallest two-sided
    # tail probability, Bonferroni-adjusted over every output (>= 0.01: consistent at 1%)
    from scipy import stats

    k = np.rint(grad.outputs * shots)
    p = np.clip(exact, 0.0, 1.0)
    tail = np.minimum(1.0, 2.0 * np.minimum(stats.binom.cdf(k, shots, p),
                                            stats.binom.sf(k - 1, shots, p)))
    bonferroni = float(min(1.0, tail.min() * tail.size))
    return {"import_s": t0, "build_s": t1 - t0, "sample_s": t2 - t1, "post_s": t3 - t2,
            "result_s": t3, "circuits": circuits, "shots": shots_spent,
            "max_z": err, "bonferroni_p": bonferroni, "samplers": samplers, "sub": len(subs),
            "result_mb": result_mb}


def _sampler_case(n: int, readout: float, sub: int, rows: int, shots: int,
                  hamming: str, direct: bool = False, jacobian: str = "sparse") -> dict:
    """Only the sampling: the plan's kind of templates built directly (no gradient plan)."""
    import numpy as np
    from qiskit import QuantumCircuit

    from qdensity import Encoding, SamplerEngine
    from qdensity.circuits.gates import RBSGate
    from qdensity.execution.plans import CircuitJob

    t0 = time.process_time()
    subs = _subs(n, sub, direct)
    loader = Encoding.unary(n).circuit
    rng = np.random.default_rng(1)
    jobs = []
    for k, body in enumerate(subs):
        for diag in (False, True):
            qc = QuantumCircuit(n, name=f"k{k}{'d' if diag else ''}")
            qc.compose(loader, inplace=True)
            qc.compose(body, inplace=True)
            if diag:  # an RBS(pi/4) on each pair of the sub-unitary, as a diagonalising layer
                for inst in body.data:
                    qc.append(RBSGate(np.pi / 4), inst.qubits)
            qc.measure_all()
            jobs.append(CircuitJob(qc, rng.uniform(-np.pi, np.pi, (rows, qc.num_parameters)),
                                   shots, qc.name))
    t1 = time.process_time()
    target = _readout_target(n, readout) if readout else None
    engine = SamplerEngine(target=target, seed=0, progress=False, hamming_weight=hamming)
    engine.run(jobs)
    t2 = time.process_time()
    samplers = sorted({e.sampler for e in engine.ledger.entries})
    return {"import_s": t0, "build_s": t1 - t0, "sample_s": t2 - t1, "post_s": float("nan"),
            "result_s": t2,
            "circuits": engine.ledger.total_circuits, "shots": engine.ledger.total_shots,
            "max_z": float("nan"), "bonferroni_p": float("nan"), "samplers": samplers,
            "sub": len(subs),
            "result_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _run_child(args: list[str], timeout: float) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    try:
        out = subprocess.run([sys.executable, __file__, "--child", *args], capture_output=True,
                             text=True, check=False, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"ran past {timeout:.0f} s (killed)"}
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    res["wall_s"] = wall
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--widths", type=int, nargs="*", default=[32, 128, 256, 1024],
                    help="noiseless widths")
    ap.add_argument("--noisy-widths", type=int, nargs="*", default=[32, 256],
                    help="widths run with the readout-noisy target")
    ap.add_argument("--readout", type=float, default=0.02,
                    help="symmetric readout error of the noisy target")
    ap.add_argument("--hamming", default="auto", choices=["auto", "never", "always"],
                    help="SamplerEngine(hamming_weight=...)")
    ap.add_argument("--sub", type=int, default=0, help="sub-unitaries kept (0: all)")
    ap.add_argument("--rows", type=int, default=16)
    ap.add_argument("--shots", type=int, default=1000)
    ap.add_argument("--timeout", type=float, default=1800, help="seconds per case")
    ap.add_argument("--sampler-only", action="store_true",
                    help="no gradient plan: time sampling the plan's kind of templates (loader "
                         "+ sub-unitary, and + an RBS(pi/4) layer on its pairs; 2 per "
                         "sub-unitary), built directly; 'build' is then building those")
    ap.add_argument("--direct-moments", action="store_true",
                    help="build each round-robin moment as its own circuit (the same pairs) "
                         "instead of by_moments(round_robin(n)); with --sub, widths whose "
                         "whole circuit does not fit in memory (n = 1024)")
    ap.add_argument("--jacobian", default="auto", choices=["auto", "sparse", "dense"],
                    help="density_gradient_plan(jacobian=...): the Jacobians' layout (auto: "
                         "no argument, the library's default)")
    ap.add_argument("--child", nargs=2, metavar=("N", "READOUT"))
    a = ap.parse_args()
    if a.child:
        n, readout = int(a.child[0]), float(a.child[1])
        case = _sampler_case if a.sampler_only else _case
        res = case(n, readout, a.sub, a.rows, a.shots, a.hamming, a.direct_moments, a.jacobian)
        res["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # Linux: KiB
        print(json.dumps(res))
        return
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores; hamming_weight="
          f"{a.hamming!r}, {a.rows} rows x {a.shots} shots, jacobian={a.jacobian!r}"
          + ("; sampler only (no gradient plan)" if a.sampler_only else ""))
    print(f"{'case':<22}{'K':>5}{'total':>8}{'result':>8}{'import':>8}{'work':>8}{'build':>8}"
          f"{'sample':>8}{'post':>8}{'wall s':>8}"
          f"{'res MB':>8}{'peak MB':>9}{'circuits':>9}{'shots':>10}{'max |z|':>8}"
          f"{'Bonf. p':>8}  sampler")
    cases = [(n, 0.0) for n in a.widths] + [(n, a.readout) for n in a.noisy_widths]
    for n, readout in cases:
        res = _run_child([str(n), str(readout), "--sub", str(a.sub), "--rows", str(a.rows),
                          "--shots", str(a.shots), "--hamming", a.hamming,
                          "--jacobian", a.jacobian]
                         + (["--sampler-only"] if a.sampler_only else [])
                         + (["--direct-moments"] if a.direct_moments else []), a.timeout)
        name = f"n={n} " + (f"readout {readout:g}" if readout else "noiseless")
        if "error" in res:
            print(f"{name:<22}  {res['error']}")
            continue
        work = res["result_s"] - res["import_s"]
        print(f"{name:<22}{res['sub']:>5}{res['cpu_s']:>8.1f}{res['result_s']:>8.1f}"
              f"{res['import_s']:>8.1f}{work:>8.1f}{res['build_s']:>8.1f}"
              f"{res['sample_s']:>8.1f}{res['post_s']:>8.1f}{res['wall_s']:>8.1f}"
              f"{res['result_mb']:>8.0f}{res['peak_mb']:>9.0f}{res['circuits']:>9}"
              f"{res['shots']:>10}"
              f"{res['max_z']:>8.2f}{res['bonferroni_p']:>8.2g}  {','.join(res['samplers'])}")


if __name__ == "__main__":
    main()
