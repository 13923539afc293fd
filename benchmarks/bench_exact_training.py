"""Exact training, seconds per epoch: qdensity's adjoint engine vs PennyLane (issue 16).

The same circuits, data sizes and batch sizes, one epoch of mini-batch gradient steps (forward
values, gradients of a squared-error loss w.r.t. every trainable angle and mixture logit, a
parameter update):

* qdensity: :class:`qdensity.learning.training.QuantumLayer` with ``engine="exact"``, i.e. the
  adjoint statevector engine the model keeps (compiled once per model);
* PennyLane ``lightning.qubit`` with ``diff_method="adjoint"`` (C++ adjoint differentiation);
* PennyLane ``default.qubit`` with ``diff_method="backprop"`` (autograd through the simulator).

Rows (the issue's): 1-qubit re-uploading with L = 10 and 50 (25 points, batch 5); the XX+YY
density model (K = 2 equivariant sub-unitaries of weight <= 3, softmax mixture, angle encoding,
``H = sum_i Z_i``) on 10 qubits (1000 samples, batch 20); the non-commuting equivariant model
(3 layers) and the QCNN on 10 qubits (1000 samples, batch 20).

Every timing runs ``--steps`` batches (default: a whole epoch for the small rows, 5 batches for
the 10-qubit rows; ``--pl-steps`` for PennyLane) and reports ``seconds per step x steps per
epoch``, wall-clock and CPU (process) time; a row that was extrapolated says so. On a shared,
loaded machine the CPU time is the fairer measure (ratios use it). The first step
(compilation, warm-up) is excluded. A correctness column compares the first step's loss
across the three (the circuits are the same, so it is ~1e-15).

Run::

    python benchmarks/bench_exact_training.py [--steps 5] [--rows reup10,reup50,xxyy,noncomm,qcnn]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits.ansatze import (
    equivariant_commuting,
    equivariant_noncommuting,
    qcnn,
    qcnn_layers,
    reuploading,
    translation_classes,
)
from qdensity.learning.training import QuantumLayer
from qdensity.models import DensityQNN, Encoding, SoftmaxMixture, independent

# ---------------------------------------------------------------------- the rows
ROWS = {
    # name: (kind, n, layers, samples, batch)
    "reup10": ("reup", 1, 10, 25, 5),
    "reup50": ("reup", 1, 50, 25, 5),
    "xxyy": ("xxyy", 10, 3, 1000, 20),
    "noncomm": ("noncomm", 10, 3, 1000, 20),
    "qcnn": ("qcnn", 10, 0, 1000, 20),
}


def _z_sum(n):
    return SparsePauliOp.from_sparse_list([("Z", [i], 1.0) for i in range(n)], n)


def qdensity_model(kind, n, layers, seed=0):
    if kind == "reup":
        return DensityQNN([reuploading(layers)], seed=seed)
    if kind == "xxyy":
        subs = independent([equivariant_commuting(n, "X", layers),
                            equivariant_commuting(n, "Y", layers)]).sub_unitaries
        return DensityQNN(subs, SoftmaxMixture(2), encoding=Encoding.angle(n),
                          observable=_z_sum(n), seed=seed)
    if kind == "noncomm":
        return DensityQNN([equivariant_noncommuting(n, layers)], encoding=Encoding.angle(n),
                          observable=_z_sum(n), seed=seed)
    obs = SparsePauliOp.from_sparse_list([("Z", [n - 1], 1.0)], n)
    return DensityQNN([qcnn(n)], encoding=Encoding.angle(n), observable=obs, seed=seed)


def data(kind, n, samples, seed=1):
    rng = np.random.default_rng(seed)
    if kind == "reup":
        X = rng.uniform(-1, 1, (samples, 1))
        return X, np.cos(3 * X[:, 0])
    X = rng.uniform(-1, 1, (samples, n))
    return X, np.tanh(X.sum(axis=1) / 2)


def qdensity_epoch(model, X, y, batch, steps, lr=0.05):
    layer = QuantumLayer(model)
    times, losses = [], []
    for step in range(steps + 1):
        idx = np.arange(step * batch, (step + 1) * batch) % X.shape[0]
        t0, c0 = time.perf_counter(), time.process_time()
        out = layer.forward(X[idx])[:, 0]
        losses.append(float(np.mean((out - y[idx]) ** 2)))
        layer.backward((2 * (out - y[idx]) / len(idx))[:, None])
        layer.set_params(model.theta - lr * layer.grads["theta"],
                         model.mixture.params - lr * layer.grads["mixture"])
        times.append((time.perf_counter() - t0, time.process_time() - c0))
    return times, losses


# ---------------------------------------------------------------------- PennyLane
def pennylane_cost(kind, n, layers, model, device, diff_method):
    """The same model in PennyLane: returns (cost(theta, logits, X, y), theta0, logits0)."""
    import pennylane as qml
    from pennylane import numpy as pnp

    dev = qml.device(device, wires=n)

    def encode(X):
        for i in range(n):
            qml.RY(np.pi / 2 * X[:, i], wires=i)

    if kind == "reup":
        @qml.qnode(dev, diff_method=diff_method)
        def circuit(theta, X):
            for layer in range(layers):
                qml.RX(X[:, 0], wires=0)
                qml.RZ(theta[3 * layer + 2], wires=0)
                qml.RY(theta[3 * layer + 1], wires=0)
                qml.RZ(theta[3 * layer], wires=0)
            return qml.expval(qml.PauliZ(0))
        subs = [circuit]
        sizes = [3 * layers]
    elif kind == "xxyy":
        classes = translation_classes(n, layers)

        def make(pauli):
            @qml.qnode(dev, diff_method=diff_method)
            def circuit(theta, X):
                encode(X)
                for c, cls in enumerate(classes):
                    for support in cls:
                        qml.PauliRot(2 * theta[c], pauli * len(support), wires=list(support))
                return qml.expval(qml.sum(*[qml.PauliZ(i) for i in range(n)]))
            return circuit
        subs = [make("X"), make("Y")]
        sizes = [len(classes), len(classes)]
    elif kind == "noncomm":
        dist = [sorted({tuple(sorted((i, (i + d) % n))) for i in range(n)})
                for d in range(1, n // 2 + 1)]
        per = 2 + len(dist)

        @qml.qnode(dev, diff_method=diff_method)
        def circuit(theta, X):
            encode(X)
            for layer in range(layers):
                b = layer * per
                for q in range(n):
                    qml.PauliRot(2 * theta[b], "Z", wires=q)
                for q in range(n):
                    qml.PauliRot(2 * theta[b + 1], "Y", wires=q)
                for d, cls in enumerate(dist):
                    for pair in cls:
                        qml.PauliRot(2 * theta[b + 2 + d], "XX", wires=list(pair))
            return qml.expval(qml.sum(*[qml.PauliZ(i) for i in range(n)]))
        subs = [circuit]
        sizes = [layers * per]
    else:
        pattern = qcnn_layers(n)

        @qml.qnode(dev, diff_method=diff_method)
        def circuit(theta, X):
            encode(X)
            for layer, (conv, pool) in enumerate(pattern):
                p = theta[12 * layer:12 * layer + 12]
                for u, v in conv:
                    qml.RX(p[0], wires=u)
                    qml.RX(p[1], wires=v)
                    qml.RZ(p[2], wires=u)
                    qml.RZ(p[3], wires=v)
                    qml.CRZ(p[4], wires=[v, u])
                    qml.CRZ(p[5], wires=[u, v])
                    qml.RX(p[6], wires=u)
                    qml.RX(p[7], wires=v)
                    qml.RZ(p[8], wires=u)
                    qml.RZ(p[9], wires=v)
                for c, t in pool:
                    qml.CRZ(p[10], wires=[c, t])
                    qml.PauliX(wires=c)
                    qml.CRX(p[11], wires=[c, t])
                    qml.PauliX(wires=c)
            return qml.expval(qml.PauliZ(n - 1))
        subs = [circuit]
        sizes = [12 * len(pattern)]
    bounds = np.cumsum([0] + sizes)

    def cost(theta, logits, X, y):
        alpha = pnp.exp(logits) / pnp.sum(pnp.exp(logits))
        f = sum(alpha[k] * sub(theta[bounds[k]:bounds[k + 1]], X) for k, sub in enumerate(subs))
        return pnp.mean((f - y) ** 2)

    theta0 = pnp.array(model.theta.copy(), requires_grad=True)
    logits0 = pnp.array(np.zeros(len(subs)), requires_grad=True)
    return cost, theta0, logits0


def pennylane_epoch(kind, n, layers, model, X, y, batch, steps, device, diff_method, lr=0.05):
    import pennylane as qml
    from pennylane import numpy as pnp

    cost, theta, logits = pennylane_cost(kind, n, layers, model, device, diff_method)
    grad = qml.grad(cost, argnums=[0, 1])
    times, losses = [], []
    for step in range(steps + 1):
        idx = np.arange(step * batch, (step + 1) * batch) % X.shape[0]
        Xb = pnp.array(X[idx], requires_grad=False)
        yb = pnp.array(y[idx], requires_grad=False)
        t0, c0 = time.perf_counter(), time.process_time()
        losses.append(float(cost(theta, logits, Xb, yb)))
        g_theta, g_logits = grad(theta, logits, Xb, yb)
        theta = theta - lr * g_theta
        logits = logits - lr * g_logits
        times.append((time.perf_counter() - t0, time.process_time() - c0))
    return times, losses


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default=",".join(ROWS))
    parser.add_argument("--steps", type=int, default=5,
                        help="batches timed for the 10-qubit rows (small rows: a full epoch)")
    parser.add_argument("--pl-steps", type=int, default=2,
                        help="batches timed for PennyLane on the 10-qubit rows")
    parser.add_argument("--skip-backprop", action="store_true")
    args = parser.parse_args(argv)
    header = (f"{'row':<9}{'steps/ep':>9}{'qdensity':>16}{'lightning':>16}{'backprop':>16}"
              f"{'light/qd':>10}{'bp/qd':>8}  {'loss check':<11} timed steps (qd, pl)")
    print("seconds per epoch, wall / CPU (mean step time x steps per epoch; first step "
          "excluded); ratios from CPU time")
    print(header)
    for name in args.rows.split(","):
        kind, n, layers, samples, batch = ROWS[name]
        per_epoch = samples // batch
        small = n == 1
        qd_steps = per_epoch if small else min(args.steps, per_epoch)
        pl_steps = per_epoch if small else min(args.pl_steps, per_epoch)
        X, y = data(kind, n, samples)
        model = qdensity_model(kind, n, layers)
        theta_start = model.theta.copy()
        t, qd_loss = qdensity_epoch(model, X, y, batch, qd_steps)
        qd = np.mean(t[1:], axis=0) * per_epoch
        model.set_params(theta_start, np.zeros_like(model.mixture.params))
        lt, l_loss = pennylane_epoch(kind, n, layers, model, X, y, batch, pl_steps,
                                     "lightning.qubit", "adjoint")
        light = np.mean(lt[1:], axis=0) * per_epoch
        if args.skip_backprop:
            bp, b_loss = np.array([np.nan, np.nan]), l_loss
        else:
            bt, b_loss = pennylane_epoch(kind, n, layers, model, X, y, batch, pl_steps,
                                         "default.qubit", "backprop")
            bp = np.mean(bt[1:], axis=0) * per_epoch
        agree = max(abs(qd_loss[0] - l_loss[0]), abs(qd_loss[0] - b_loss[0]))
        note = "full epoch" if small else f"{qd_steps}, {pl_steps} (extrapolated)"

        def cell(v):
            return f"{v[0]:.3g} / {v[1]:.3g}"

        print(f"{name:<9}{per_epoch:>9}{cell(qd):>16}{cell(light):>16}{cell(bp):>16}"
              f"{light[1] / qd[1]:>10.1f}{bp[1] / qd[1]:>8.1f}  {agree:<11.1e} {note}",
              flush=True)


if __name__ == "__main__":
    main()
