"""Readout mitigation and Hamming-weight post-selection through ``SamplerEngine``: the error of
``<Z_0>`` (a unary loader followed by a round-robin sub-unitary, random angles per seed)
against the exact value, raw, post-selected, M3, and both, on three calibrated device snapshots
over several seeds. The four variants of one seed sample the same shots (same engine seed), so
the columns compare corrections, not draws.

    python benchmarks/bench_mitigation.py [--seeds 10] [--shots 4000] [--n 4]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from qiskit.quantum_info import SparsePauliOp, Statevector

from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.plans import expectation_plan
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.hardware.targets import get_target

VARIANTS = {"raw": {}, "post-selected": {"postselect": "hamming_weight"},
            "M3": {"mitigation": "m3"},
            "both": {"mitigation": "m3", "postselect": "hamming_weight"}}


def _circuit(n: int, seed: int):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=n)
    sub = round_robin(n)
    qc = unary_loader(x).compose(sub.assign_parameters(rng.uniform(-np.pi, np.pi,
                                                                   sub.num_parameters)))
    return qc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--shots", type=int, default=4000)
    ap.add_argument("--n", type=int, default=4)
    ap.add_argument("--devices", nargs="+", default=["fake_manila", "fake_lima", "fake_quito"])
    a = ap.parse_args()
    obs = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], a.n)
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores; n = {a.n}, "
          f"{a.shots} shots, {a.seeds} seeds")
    print(f"{'device':<14}" + "".join(f"{v:>18}" for v in VARIANTS) + f"{'cal shots':>11}"
          f"{'seconds':>9}")
    for name in a.devices:
        target = get_target(name)
        errors = {v: [] for v in VARIANTS}
        cal = 0
        t = time.perf_counter()
        for seed in range(a.seeds):
            qc = _circuit(a.n, seed)
            exact = float(np.real(Statevector(qc).expectation_value(obs)))
            for v, options in VARIANTS.items():
                engine = SamplerEngine(target=target, seed=100 + seed, progress=False, **options)
                est = expectation_plan(qc, obs, [], shots=a.shots).run(engine)
                errors[v].append(abs(float(est.value[0]) - exact))
                cal += engine.ledger.by_label().get("readout calibration", (0, 0))[1]
        cells = "".join(f"{np.mean(e):.4f} ({np.std(e, ddof=1) / np.sqrt(len(e)):.4f})".rjust(18)
                        for e in errors.values())
        ratios = "".join(f"x{np.mean(e) / np.mean(errors['raw']):.2f}".rjust(18)
                         for e in errors.values())
        print(f"{name:<14}{cells}{cal:>11}{time.perf_counter() - t:>9.1f}")
        print(f"{'  / raw':<14}{ratios}")
    print("cells: mean |estimate - exact| over seeds (its standard error); cal shots: readout "
          "calibration shots spent by the M3 engines")


if __name__ == "__main__":
    main()
