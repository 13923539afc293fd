"""qiskit-machine-learning gradient training at 8 qubits: our sampler and gradient against
qiskit's sampler with qiskit-ml's own parameter shift (issue 42, item 4).

Both routes train the same ``SamplerQNN`` + ``NeuralNetworkClassifier`` (a unary model: X on
qubit 0, the data as RBS angles of a chain loader, a pyramid ansatz; classes read off which half
of the qubits holds the excitation) on the same data, from the same initial point, with the same
optimiser (qiskit-ml's ADAM) and iterations and the same shots per circuit:

* ``hamming``: ``sampler=HammingWeightSampler()``, ``gradient=HammingShiftSamplerGradient(...)``
  (the four-term rule, one PUB per circuit with every shifted row of every sample);
* ``qiskit``: ``sampler=qiskit.primitives.StatevectorSampler()`` and qiskit-ml's default
  gradient (``ParamShiftSamplerGradient``: RBS re-expressed as ``rxx`` + ``ryy``, one PUB per
  shifted row);
* ``aer`` (with ``--aer``): qiskit-aer's ``SamplerV2`` with the same default gradient, on the
  circuit rewritten by :func:`~qdensity.circuits.interop.standard_gates` (Aer's primitives do
  not unroll custom gates).

Reported per route: CPU seconds of ``fit`` (``time.process_time``, this process only; the
routes run interleaved, one after the other, ``--repeats`` times), circuits (parameter rows
submitted) and PUBs, train and test accuracy, final loss, and the CPU ratio to ``hamming``.

Measured (defaults, one repeat, a shared 2-core machine): hamming 1.23 s CPU in 6 PUBs,
qiskit 77.9 s (63x) and aer 90.7 s (74x) in 2,691 PUBs; 2,712 circuits each; train/test
accuracy 0.75/0.375 on every route.

Run::

    python benchmarks/bench_qiskit_ml.py [--qubits 8] [--samples 8] [--iterations 3]
        [--shots 1024] [--repeats 1] [--aer] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from qiskit import QuantumCircuit
from qiskit.circuit import ParameterVector
from qiskit.primitives import BaseSamplerV2, StatevectorSampler
from qiskit.quantum_info import Statevector
from qiskit_machine_learning.algorithms import NeuralNetworkClassifier
from qiskit_machine_learning.neural_networks import SamplerQNN
from qiskit_machine_learning.optimizers import ADAM

from qdensity.circuits.ansatze import pyramid
from qdensity.circuits.gates import RBSGate
from qdensity.circuits.interop import standard_gates
from qdensity.execution.samplers.hamming import HammingWeightSampler
from qdensity.gradients.qiskit_ml import HammingShiftSamplerGradient
from qdensity.io import atomic_write_text


class Counting(BaseSamplerV2):
    """A sampler that passes PUBs on and counts them and their parameter rows."""

    def __init__(self, inner: BaseSamplerV2):
        self.inner, self.pubs, self.rows = inner, 0, 0

    def run(self, pubs, *, shots=None):
        pubs = list(pubs)
        self.pubs += len(pubs)
        for pub in pubs:
            values = pub[1] if isinstance(pub, tuple) and len(pub) > 1 else None
            self.rows += int(np.prod(np.shape(values)[:-1])) if values is not None and \
                np.ndim(values) > 1 else 1
        return self.inner.run(pubs, shots=shots)


def model(n: int):
    x = ParameterVector("x", n - 1)
    qc = QuantumCircuit(n)
    qc.x(0)
    for i in range(n - 1):
        qc.append(RBSGate(x[i]), [i, i + 1])
    ansatz = pyramid(n)
    qc.compose(ansatz, inplace=True)
    return qc, list(x), list(ansatz.parameters)


def dataset(qc, n, inputs_, weights, samples, seed):
    """Labels of a teacher with the same circuit: is the excitation in the upper half?"""
    rng = np.random.default_rng(seed)
    data = rng.uniform(0, np.pi / 2, (2 * samples, n - 1))
    teacher = rng.uniform(-np.pi, np.pi, len(weights))
    upper = [1 << j for j in range(n // 2, n)]
    p1 = np.array([Statevector(qc.assign_parameters(np.concatenate([x, teacher])))
                   .probabilities()[upper].sum() for x in data])
    labels = (p1 > np.median(p1)).astype(int)
    return data[:samples], labels[:samples], data[samples:], labels[samples:]


def train(route: str, qc, inputs_, weights, n, data, shots, iterations, seed):
    def interpret(k: int) -> int:
        return int(k >= 1 << (n // 2))

    if route == "hamming":
        forward = Counting(HammingWeightSampler(seed=seed, default_shots=shots))
        backward = Counting(HammingWeightSampler(seed=seed + 1))
        gradient = HammingShiftSamplerGradient(backward, {"shots": shots})
    else:
        if route == "qiskit":
            inner = StatevectorSampler(default_shots=shots, seed=seed)
        else:
            from qiskit_aer.primitives import SamplerV2 as AerSampler

            inner = AerSampler(default_shots=shots, seed=seed)
            qc = standard_gates(qc)  # Aer's primitives do not unroll custom gates
        forward = backward = Counting(inner)
        gradient = None  # qiskit-ml's default: ParamShiftSamplerGradient on the same sampler
    qnn = SamplerQNN(circuit=qc, input_params=inputs_, weight_params=weights,
                     interpret=interpret, output_shape=2, sampler=forward, gradient=gradient)
    losses: list[float] = []
    clf = NeuralNetworkClassifier(qnn, optimizer=ADAM(maxiter=iterations, lr=0.1),
                                  initial_point=np.random.default_rng(9).uniform(
                                      -np.pi, np.pi, len(weights)),
                                  callback=lambda *args: losses.append(float(args[-1])))
    x_train, y_train, x_test, y_test = data
    start = time.process_time()
    clf.fit(x_train, y_train)
    cpu = time.process_time() - start
    pubs = forward.pubs + (backward.pubs if backward is not forward else 0)
    rows = forward.rows + (backward.rows if backward is not forward else 0)
    return {"route": route, "cpu_s": cpu, "pubs": pubs, "circuits": rows,
            "train_accuracy": float(clf.score(x_train, y_train)),
            "test_accuracy": float(clf.score(x_test, y_test)),
            "first_loss": losses[0] if losses else None,
            "final_loss": losses[-1] if losses else None}


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qubits", type=int, default=8)
    parser.add_argument("--samples", type=int, default=8, help="training (and test) samples")
    parser.add_argument("--iterations", type=int, default=3, help="ADAM iterations")
    parser.add_argument("--shots", type=int, default=1024, help="shots per circuit")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--aer", action="store_true", help="also qiskit-aer's SamplerV2")
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")
    n = args.qubits
    qc, inputs_, weights = model(n)
    data = dataset(qc, n, inputs_, weights, args.samples, args.seed)
    routes = ["hamming", "qiskit"] + (["aer"] if args.aer else [])
    print(f"{n} qubits, {len(weights)} weights, {args.samples} samples, {args.iterations} ADAM "
          f"iterations, {args.shots} shots per circuit")
    print(f"{'route':8s} {'CPU s':>9s} {'ratio':>7s} {'PUBs':>8s} {'circuits':>9s} "
          f"{'train acc':>9s} {'test acc':>8s} {'loss':>13s}", flush=True)
    rows = []
    for _ in range(args.repeats):
        base = None
        for route in routes:  # interleaved: each repeat runs every route once
            r = train(route, qc, inputs_, weights, n, data, args.shots, args.iterations,
                      args.seed)
            base = r["cpu_s"] if route == "hamming" else base
            r["cpu_ratio_to_hamming"] = r["cpu_s"] / base
            rows.append(r)
            print(f"{r['route']:8s} {r['cpu_s']:9.2f} {r['cpu_ratio_to_hamming']:7.1f} "
                  f"{r['pubs']:8d} {r['circuits']:9d} {r['train_accuracy']:9.3f} "
                  f"{r['test_accuracy']:8.3f} {r['first_loss']:6.3f}->{r['final_loss']:.3f}",
                  flush=True)
    if args.json:
        atomic_write_text(args.json, json.dumps({"args": vars(args), "rows": rows}, indent=2))
    return rows


if __name__ == "__main__":
    main()
