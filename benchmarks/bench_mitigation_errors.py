"""Reported standard errors of readout-mitigated estimates against their spread over seeds.

Usage: ``python benchmarks/bench_mitigation_errors.py [--seeds 100] [--shots 4000]
[--calibration-shots 500] [--postselect] [--wide 14]`` from the repository root (not part of
CI).

On a 4-qubit device whose only noise is a readout error (0 -> 1 with 0.03, 1 -> 0 with 0.12),
each seed runs a fresh calibration and fresh shots of ``<Z_0> - 0.5 <Z_1>`` on three unary
states (a basis state, a near-basis one, a spread one), through
:func:`~qdensity.execution.sampler.mitigated.mitigated_expectation` and through a
``SamplerEngine(mitigation="m3")``. It prints, per state and path, the bias of the mean, the
spread (sd over seeds), the root-mean-square reported error and their variance ratio; a
ratio near 1 (within the chi-square(seeds - 1) spread, about +-0.3 at 100 seeds) means the
reported errors are right. ``--wide N`` adds an ``N``-qubit register in ``|1...1>``
(``<Z_0> + 0.5 <Z_0 Z_1>``, exact -0.5, engine path, no post-selection): hundreds of observed
outcomes per row, where mthree's overhead ``M`` is large and its correction on the observed
outcomes alone leaves a bias.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--shots", type=int, default=4000)
    parser.add_argument("--calibration-shots", type=int, default=500)
    parser.add_argument("--postselect", action="store_true",
                        help="keep Hamming weight 1 (default: every outcome)")
    parser.add_argument("--wide", type=int, default=0, metavar="N",
                        help="also an N-qubit |1...1> register (0: none)")
    args = parser.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.path.insert(0, os.getcwd())
    from qiskit.providers.fake_provider import GenericBackendV2
    from qiskit.quantum_info import SparsePauliOp
    from qiskit_aer.noise import NoiseModel, ReadoutError

    from qdensity.circuits.loaders import unary_loader
    from qdensity.execution.plans import expectation_plan
    from qdensity.execution.sampler.engine import SamplerEngine
    from qdensity.execution.sampler.mitigated import mitigated_expectation
    from qdensity.hardware.mitigation import ReadoutMitigator
    from qdensity.hardware.targets import get_target

    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[0.97, 0.03], [0.12, 0.88]]))
    tgt = get_target(GenericBackendV2(4, seed=3).target, noise_model=noise)
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("Z", [1], -0.5)], 4)
    states = {"basis": [1.0, 0.0, 0.0, 0.0], "near": [0.995, 0.07, 0.05, 0.03],
              "spread": [0.6, 0.5, 0.45, 0.43]}
    from qiskit import QuantumCircuit

    def wide_case(n):
        wtgt = get_target(GenericBackendV2(n, seed=3).target, noise_model=noise)
        qc = QuantumCircuit(n)
        qc.x(range(n))
        wobs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0), ("ZZ", [0, 1], 0.5)], n)
        return wtgt, qc, wobs, -0.5

    print(f"load average {os.getloadavg()[0]:.2f}; seeds {args.seeds}, shots {args.shots}, "
          f"calibration shots {args.calibration_shots}, postselect {args.postselect}")
    print(f"{'state':<8}{'path':<8}{'bias':>9}{'sd':>9}{'rms se':>9}{'ratio':>8}{'s':>6}")
    cases = []
    for name, x in states.items():
        a = np.array(x) ** 2 / np.sum(np.array(x) ** 2)
        cases.append((name, tgt, unary_loader(x), obs, (1 - 2 * a[0]) - 0.5 * (1 - 2 * a[1]),
                      ("fn", "engine")))
    if args.wide:
        cases.append((f"wide{args.wide}", *wide_case(args.wide), ("engine",)))
    for name, tgt, qc, obs, exact, paths in cases:
        for path in paths:
            t0 = time.perf_counter()
            values, errors = [], []
            for seed in range(args.seeds):
                if path == "fn":
                    eng = SamplerEngine(target=tgt, seed=seed, progress=False)
                    mit = ReadoutMitigator(tgt, shots=args.calibration_shots, seed=10**6 + seed)
                    est = mitigated_expectation(qc, obs, [], engine=eng, shots=args.shots,
                                                mitigator=mit,
                                                postselect=1 if args.postselect else None)
                else:
                    eng = SamplerEngine(target=tgt, seed=seed, progress=False, mitigation="m3",
                                        postselect="hamming_weight" if args.postselect else None,
                                        calibration_shots=args.calibration_shots)
                    est = expectation_plan(qc, obs, [], shots=args.shots).run(eng)
                values.append(est.value[0])
                errors.append(est.standard_error[0])
            v, e = np.array(values), np.array(errors)
            print(f"{name:<8}{path:<8}{v.mean() - exact:>+9.4f}{v.std(ddof=1):>9.4f}"
                  f"{np.sqrt(np.mean(e**2)):>9.4f}{v.var(ddof=1) / np.mean(e**2):>8.2f}"
                  f"{time.perf_counter() - t0:>6.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
