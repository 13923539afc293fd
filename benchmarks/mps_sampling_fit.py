"""Does Aer's matrix-product-state sampler draw from the exact distribution? (not part of CI).

Usage: ``python benchmarks/mps_sampling_fit.py [--qubits 14] [--shots 200000] [--seed 11]``
from the repository root. Three circuits at a width a statevector still holds, transpiled once
as :class:`~qdensity.SamplerEngine` does (a unary loader; the loader followed by a round-robin
sub-unitary at random angles; a two-layer ``ry``/``cx`` line, which is not Hamming-weight-1):
each is sampled by Aer's ``statevector`` method and by ``matrix_product_state`` with its three
``mps_sample_measure_algorithm`` settings, and every sample is compared with the exact
outcome distribution of the compiled circuit (``Statevector``, clbits mapped through the
measurements). Printed per sample: the chi-square goodness of fit (cells of expected count
below 5 pooled) and its p-value, the smallest two-sided exact binomial p-value over the
outcomes times their number (Bonferroni), the count on outcomes of exact probability 0, and
two checks of the shots' order (chi-square homogeneity of 10 consecutive blocks; the z-score
of the fraction of consecutive equal outcomes against ``sum p**2``). Under an unbiased sampler
of independent shots the p-values are uniform and the z-score standard normal.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from qiskit import QuantumCircuit
from qiskit.quantum_info import Statevector
from qiskit_aer.primitives import SamplerV2
from scipy import stats

from qdensity import SamplerEngine, by_moments
from qdensity.circuits.ansatze import round_robin
from qdensity.circuits.loaders import unary_loader
from qdensity.execution.plans import measured
from qdensity.execution.sampler.engine import bitarray_to_bits

SAMPLERS = [("statevector", {}), ("matrix_product_state", {})] + [
    ("matrix_product_state", {"mps_sample_measure_algorithm": alg})
    for alg in ("mps_apply_measure", "mps_probabilities")]


def exact_clbit_probabilities(compiled: QuantumCircuit) -> np.ndarray:
    """Exact distribution ``(2**clbits,)`` of a measured circuit's clbits."""
    where = {compiled.find_bit(i.qubits[0]).index: compiled.find_bit(i.clbits[0]).index
             for i in compiled.data if i.operation.name == "measure"}
    qubits = sorted(where)
    probs = Statevector(compiled.remove_final_measurements(inplace=False)).probabilities(qubits)
    idx = np.arange(probs.size)
    cl = np.zeros_like(idx)
    for k, q in enumerate(qubits):
        cl |= ((idx >> k) & 1) << where[q]
    out = np.zeros(2**compiled.num_clbits)
    np.add.at(out, cl, probs)
    return out


def fit(counts: np.ndarray, p: np.ndarray, shots: int) -> tuple:
    """Chi-square statistic, dof, p-value; Bonferroni binomial p; counts where p == 0."""
    e = shots * p
    big = e >= 5
    obs, exp = np.append(counts[big], counts[~big].sum()), np.append(e[big], e[~big].sum())
    if exp[-1] == 0:
        obs, exp = obs[:-1], exp[:-1]
    chi2 = float(np.sum((obs - exp) ** 2 / exp))
    dof = obs.size - 1
    pos = p > 1e-14
    c, q = counts[pos], p[pos]
    two = np.minimum(1, 2 * np.minimum(stats.binom.cdf(c, shots, q),
                                       stats.binom.sf(c - 1, shots, q)))
    return (chi2, dof, stats.chi2.sf(chi2, dof), min(1.0, float(two.min() * pos.sum())),
            int(counts[~pos].sum()))


def order(idx: np.ndarray, p: np.ndarray, blocks: int = 10) -> tuple[float, float]:
    """Homogeneity p-value of consecutive shot blocks; z of consecutive repeats."""
    parts = np.array_split(idx, blocks)
    cells = np.flatnonzero(p * idx.size / blocks >= 5)
    table = np.array([[np.sum(b == c) for c in cells] + [np.sum(~np.isin(b, cells))]
                      for b in parts])
    table = table[:, table.sum(axis=0) > 0]
    same, want = np.mean(idx[1:] == idx[:-1]), np.sum(p**2)
    return (stats.chi2_contingency(table).pvalue,
            (same - want) / np.sqrt(want * (1 - want) / (idx.size - 1)))


def circuits(n: int, rng: np.random.Generator):
    x = rng.normal(size=n)
    x[:3] *= 4
    yield "unary loader", unary_loader(x)
    sub = by_moments(round_robin(n)).sub_unitaries[1]
    angles = rng.uniform(-np.pi, np.pi, sub.num_parameters)
    yield "loader + round-robin sub-unitary", unary_loader(x).compose(
        sub.assign_parameters(angles))
    line = QuantumCircuit(n)
    for layer in range(2):
        for q in range(n):
            line.ry(rng.uniform(0, np.pi), q)
        for q in range(layer % 2, n - 1, 2):
            line.cx(q, q + 1)
    yield "ry/cx line", line


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qubits", type=int, default=14)
    parser.add_argument("--shots", type=int, default=200_000)
    parser.add_argument("--seed", type=int, default=11)
    args = parser.parse_args(argv)
    n, shots = args.qubits, args.shots
    print(f"{'circuit':<34}{'sampler':<40}{'chi2/dof':>14}{'p':>8}{'binom p':>9}"
          f"{'p=0 hits':>9}{'blocks p':>9}{'z repeat':>9}{'s':>6}")
    for name, qc in circuits(n, np.random.default_rng(n)):
        compiled = SamplerEngine(seed=0, progress=False).compiled(measured(qc))
        p = exact_clbit_probabilities(compiled)
        for method, extra in SAMPLERS:
            t0 = time.perf_counter()
            opts = {"method": method, "max_parallel_threads": 1, **extra}
            sampler = SamplerV2(seed=args.seed, options={"backend_options": opts})
            data = sampler.run([(compiled, None, shots)]).result()[0].join_data()
            bits = bitarray_to_bits(data, 1, shots)[0]
            idx = bits.astype(np.int64) @ (1 << np.arange(bits.shape[1], dtype=np.int64))
            chi2, dof, pv, binom_p, zero = fit(np.bincount(idx, minlength=p.size), p, shots)
            blocks, z = order(idx, p)
            label = method + (f" {extra['mps_sample_measure_algorithm']}" if extra else "")
            print(f"{name:<34}{label:<40}{f'{chi2:.0f}/{dof}':>14}{pv:>8.3f}{binom_p:>9.3f}"
                  f"{zero:>9d}{blocks:>9.3f}{z:>+9.2f}{time.perf_counter() - t0:>6.0f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
