"""Cost of the three density-QNN preparations (paper Fig. 1a/b/c) after transpiling.

For each workload the script builds, on ``n`` data qubits with the unary loader template
``V(x)`` in front:

* Fig. 1c, randomised: ``K`` circuits ``U_k V(x)`` (one runs per shot);
* Fig. 1b, deterministic: ``Load(sqrt(alpha))`` on ``K`` ancillas + ``K`` controlled ``U_k``;
* Fig. 1a, LCU: Fig. 1b followed by ``Load(sqrt(alpha))^dagger``;
* a naive deterministic circuit whose controlled ``U_k`` come from Qiskit's generic
  ``Gate.control(1)`` on every gate, to show what the structured control saves.

Every circuit is transpiled as a parameterised template (as an engine would, once per
template) to ``basis_gates=["cz", "rz", "sx", "x"]`` at ``optimization_level=3`` with no
coupling map, and the table reports the two-qubit (CZ) count and depth. Ratios are against
the largest randomised circuit, which is what one shot of Fig. 1c costs.

Workloads (``n = 8`` by default):

* ``rr-layers K=4``: the first 4 layers of the round-robin ansatz (Fig. 6 decomposition),
  4 RBS gates each, every layer its own sub-unitary;
* ``rr-layers K=7``: all ``n - 1 = 7`` round-robin layers (the paper's decomposition);
* ``hea K=4`` / ``hea K=8``: hardware-efficient layers (rx, ry on every qubit, CNOT ladder),
  one layer per sub-unitary.

Run: ``python benchmarks/bench_preparation.py [--n 8] [--seed 7]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from qiskit import QuantumCircuit, QuantumRegister, transpile
from qiskit.circuit import ParameterVector

from qdensity.circuits.ansatze import pairs_circuit, round_robin_pairs
from qdensity.circuits.loaders import distribution_loader, unary_loader_template
from qdensity.circuits.preparation import deterministic_circuit, lcu_circuit, randomised_circuits

BASIS = ["cz", "rz", "sx", "x"]


def round_robin_layers(n: int, K: int) -> list[QuantumCircuit]:
    rounds = round_robin_pairs(n)
    return [pairs_circuit(n, [rounds[k % len(rounds)]], parameter_prefix=f"rr{k}")
            for k in range(K)]


def hea_layers(n: int, K: int) -> list[QuantumCircuit]:
    out = []
    for k in range(K):
        theta = ParameterVector(f"h{k}", 2 * n)
        qc = QuantumCircuit(n, name=f"hea_{k}")
        for q in range(n):
            qc.rx(theta[2 * q], q)
            qc.ry(theta[2 * q + 1], q)
        for q in range(n - 1):
            qc.cx(q, q + 1)
        out.append(qc)
    return out


def naive_deterministic(subs, alpha, loader) -> QuantumCircuit:
    """Fig. 1b with every gate of U_k controlled by Qiskit's generic ``Gate.control(1)``."""
    K, n = len(subs), subs[0].num_qubits
    mix, data = QuantumRegister(K, "mix"), QuantumRegister(n, "data")
    qc = QuantumCircuit(mix, data)
    qc.compose(distribution_loader(alpha), mix, inplace=True)
    qc.compose(loader, data, inplace=True)
    for k, sub in enumerate(subs):
        for inst in sub.data:
            qubits = [data[sub.find_bit(q).index] for q in inst.qubits]
            qc.append(inst.operation.control(1), [mix[k], *qubits])
    return qc


def cost(qc: QuantumCircuit, seed: int) -> tuple[int, int]:
    tqc = transpile(qc, basis_gates=BASIS, optimization_level=3, seed_transpiler=seed)
    return int(tqc.count_ops().get("cz", 0)), int(tqc.depth())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=8, help="data qubits (default 8)")
    parser.add_argument("--seed", type=int, default=7, help="alpha and transpiler seed")
    args = parser.parse_args()
    n, seed = args.n, args.seed
    rng = np.random.default_rng(seed)
    loader = unary_loader_template(n)
    workloads = {
        "rr-layers K=4": round_robin_layers(n, 4),
        "rr-layers K=7": round_robin_layers(n, n - 1),
        "hea K=4": hea_layers(n, 4),
        "hea K=8": hea_layers(n, 8),
    }
    header = (
        f"{'workload':<15}{'circuit':<16}{'2q (CZ)':>9}{'depth':>8}"
        f"{'2q / rand-max':>15}{'depth / rand-max':>18}"
    )
    print(f"n = {n} data qubits, basis {BASIS}, optimization_level=3, parameterised templates")
    print(header)
    print("-" * len(header))
    for label, subs in workloads.items():
        start = time.perf_counter()
        K = len(subs)
        alpha = rng.dirichlet(np.ones(K))
        rand = [cost(c, seed) for c in randomised_circuits(subs, loader)]
        rand_2q = np.array([c[0] for c in rand])
        rand_depth = np.array([c[1] for c in rand])
        max_2q, max_depth = int(rand_2q.max()), int(rand_depth.max())
        rows = [
            ("randomised max", max_2q, max_depth),
            ("randomised mean", float(rand_2q.mean()), float(rand_depth.mean())),
            ("deterministic", *cost(deterministic_circuit(subs, alpha, loader), seed)),
            ("lcu", *cost(lcu_circuit(subs, alpha, loader), seed)),
            ("naive determ.", *cost(naive_deterministic(subs, alpha, loader), seed)),
        ]
        for name, two_q, depth in rows:
            print(
                f"{label:<15}{name:<16}{two_q:>9.1f}{depth:>8.1f}"
                f"{two_q / max_2q:>15.2f}{depth / max_depth:>18.2f}"
            )
        print(f"{'':<15}(built and transpiled in {time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
