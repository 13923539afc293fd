"""Seconds per training epoch on digits (PCA to 8), round-robin models, exact gradients.

The same circuits (parallel unary loader + round-robin RBS ansatz on 8 qubits, the pure model
and its layer-by-layer density version with a softmax mixture, an 8 -> 10 linear read-out,
cross entropy, Adam, batch 32) trained three ways:

* ``numpy``: :class:`qdensity.QNNClassifier` (unary engine reverse mode, numpy read-out);
* ``torch``: :class:`qdensity.learning.torch.DensityQNNLayer` in a ``torch.nn.Sequential``
  with a ``torch.nn.Linear`` read-out and ``torch.optim.Adam`` (``fused=True`` by default:
  one kernel for all parameters, as the numpy estimator's Adam updates one flat vector; the
  per-tensor default implementation costs a few hundred microseconds a step on these tiny
  tensors; ``--torch-adam default`` times it);
* ``pennylane``: the same gates as ``qml.SingleExcitation`` (RBS(t) on qubits (i, j) is
  ``SingleExcitation(2 t)`` on wires ``[j, i]``), a QNode per sub-unitary with parameter
  broadcasting over the batch and the torch interface: ``default.qubit`` with backprop and
  ``lightning.qubit`` with the adjoint method (``pip install -e ".[bench,torch]"``).

PennyLane epochs are timed on ``--pl-batches`` batches and scaled to a full epoch (stated in
the table). ``--clock cpu`` times CPU seconds of the process instead of wall seconds, which a
busy shared machine disturbs less. Every configuration also reports the test accuracy after
its epochs, so the table says the implementations learn the same thing. Goals (issue
"Learning"): torch adds at most 20% to numpy; both at least 25x faster than PennyLane's best
configuration.

Run::

    python benchmarks/bench_training.py [--epochs 3] [--pl-batches 5] [--skip-pennylane] \\
        [--clock cpu]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.datasets.digits import load_digits_features
from qdensity.learning.estimators import QNNClassifier
from qdensity.learning.nn import Linear
from qdensity.models import DensityQNN, Encoding
from qdensity.models.decompositions import by_moments
from qdensity.models.mixtures import SoftmaxMixture

N = 8
BATCH = 32
CLOCK = time.perf_counter  # --clock cpu: time.process_time


def models(seed: int = 0) -> dict[str, DensityQNN]:
    enc = Encoding.unary(N)
    pure = DensityQNN([round_robin(N)], encoding=enc, readout="unary_probabilities", seed=seed)
    dec = by_moments(round_robin(N))
    dens = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), encoding=enc,
                      readout="unary_probabilities")
    dens.set_params(theta=pure.theta)
    return {"pure": pure, "density": dens}


def bench_numpy(model, data, epochs):
    X_tr, X_te, y_tr, y_te = data
    marks = []  # the clock before the first step and after every step
    clf = QNNClassifier(model, post=Linear(N, 10, seed=0), learning_rate=0.01, epochs=epochs,
                        batch_size=BATCH, seed=0, verbose=False,
                        callback=lambda est, step: marks.append(CLOCK()))
    clf.fit(X_tr, y_tr)
    steps = -(-len(X_tr) // BATCH)  # each epoch's time, the fastest as for torch
    return min(np.diff(marks[::steps])), clf.score(X_te, y_te)


def _adam(params, kind):
    import torch

    if kind == "fused":
        try:
            return torch.optim.Adam(params, lr=0.01, fused=True)
        except (RuntimeError, TypeError, ValueError):  # torch < 2.4: no fused Adam on CPU
            pass
    return torch.optim.Adam(params, lr=0.01)


def bench_torch(model, data, epochs, adam="fused"):
    import torch
    from torch import nn

    from qdensity.learning.torch import DensityQNNLayer

    torch.manual_seed(0)
    X_tr, X_te, y_tr, y_te = (torch.tensor(a) for a in data)
    net = nn.Sequential(DensityQNNLayer(model), nn.Linear(N, 10, dtype=torch.float64))
    opt = _adam(list(net.parameters()), adam)
    gen = torch.Generator().manual_seed(0)
    times = []
    for _ in range(epochs):
        t = CLOCK()
        order = torch.randperm(len(X_tr), generator=gen)
        for s in range(0, len(order), BATCH):
            idx = order[s:s + BATCH]
            opt.zero_grad()
            nn.functional.cross_entropy(net(X_tr[idx]), y_tr[idx]).backward()
            opt.step()
        times.append(CLOCK() - t)
    with torch.no_grad():
        acc = float((net(X_te).argmax(1) == y_te).double().mean())
    return min(times), acc


def _pl_gate_lists(model):
    """Per sub-unitary: [(wires, theta index)] of its RBS gates, read off the Qiskit circuit."""
    out = []
    for k, sub in enumerate(model.sub_unitaries):
        idx = model.subunitary_parameter_indices(k)
        local = {p: i for i, p in enumerate(sub.parameters)}
        gates = []
        for inst in sub.data:
            i, j = (sub.find_bit(q).index for q in inst.qubits)
            (param,) = inst.operation.params[0].parameters
            gates.append(((j, i), int(idx[local[param]])))
        out.append(gates)
    return out


def bench_pennylane(model, data, device, diff_method, batches, adam="fused"):
    import pennylane as qml
    import torch
    from torch import nn

    from qdensity.circuits.loaders import loader_angles

    X_tr, X_te, y_tr, y_te = data
    enc = model.encoding.circuit
    loader = []  # (wires, loader angle column) in circuit order; X on the start qubit first
    start = None
    for inst in enc.data:
        qs = [enc.find_bit(q).index for q in inst.qubits]
        if inst.operation.name == "x":
            start = qs[0]
        else:
            loader.append(((qs[1], qs[0]), len(loader)))
    gate_lists = _pl_gate_lists(model)
    dev = qml.device(device, wires=N)

    def make_qnode(gates):
        @qml.qnode(dev, interface="torch", diff_method=diff_method)
        def circuit(phi, theta):
            qml.PauliX(wires=start)
            for wires, c in loader:
                qml.SingleExcitation(2 * phi[:, c], wires=list(wires))
            for wires, p in gates:
                qml.SingleExcitation(2 * theta[p], wires=list(wires))
            # on Hamming-weight-1 states the unary probabilities are p_j = (1 - <Z_j>) / 2;
            # expectation values suit both backprop and the adjoint method
            return [qml.expval(qml.PauliZ(w)) for w in range(N)]
        return circuit

    qnodes = [make_qnode(g) for g in gate_lists]
    torch.manual_seed(0)
    theta = nn.Parameter(torch.tensor(model.theta))
    logits = nn.Parameter(torch.zeros(len(qnodes), dtype=torch.float64))
    head = nn.Linear(N, 10, dtype=torch.float64)
    opt = _adam([theta, logits, *head.parameters()], adam)

    def forward(X):
        phi = torch.tensor(loader_angles(X))
        outs = torch.stack([(1 - torch.stack(q(phi, theta), dim=-1).to(torch.float64)) / 2
                            for q in qnodes], dim=1)
        return head(torch.einsum("k,bkm->bm", torch.softmax(logits, 0), outs))

    with torch.no_grad():  # the same function as qdensity's model, before any training
        phi = torch.tensor(loader_angles(X_te[:16]))
        f_pl = torch.stack([(1 - torch.stack(q(phi, theta), dim=-1).to(torch.float64)) / 2
                            for q in qnodes], dim=1).numpy()
    mismatch = float(np.abs(f_pl - model.expert_outputs(X_te[:16])).max())
    y = torch.tensor(y_tr)
    steps = -(-len(X_tr) // BATCH)
    order = np.random.default_rng(0).permutation(len(X_tr))
    t = CLOCK()
    for s in range(batches):
        idx = order[s * BATCH:(s + 1) * BATCH]
        opt.zero_grad()
        nn.functional.cross_entropy(forward(X_tr[idx]), y[idx]).backward()
        opt.step()
    per_epoch = (CLOCK() - t) / batches * steps
    with torch.no_grad():
        acc = float((forward(X_te).argmax(1) == torch.tensor(y_te)).double().mean())
    return per_epoch, acc, mismatch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=3,
                        help="epochs of the numpy and torch runs; each reports its fastest")
    parser.add_argument("--pl-batches", type=int, default=5)
    parser.add_argument("--skip-pennylane", action="store_true")
    parser.add_argument("--torch-adam", choices=("fused", "default"), default="fused",
                        help="torch.optim.Adam implementation (torch layer and PennyLane runs)")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="wall: perf_counter; cpu: process_time, the CPU seconds of this "
                             "process (all its threads), steadier on a shared machine")
    parser.add_argument("--torch-threads", type=int, default=1,
                        help="torch intra-op threads (1: these tensors are tiny, and more "
                             "threads spin-wait on a shared machine)")
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    try:
        import torch

        torch.set_num_threads(args.torch_threads)
    except ImportError:
        pass
    data = load_digits_features(N, 300, 7)
    print(f"digits, PCA to {N}, {len(data[0])} training rows, batch {BATCH} "
          f"({-(-len(data[0]) // BATCH)} steps per epoch), exact gradients, torch Adam "
          f"{args.torch_adam}, {args.torch_threads} torch thread(s), {args.clock} clock\n")
    print(f"{'model':<8} {'implementation':<34} {'s/epoch':>9} {'test acc':>9} {'vs numpy':>9}")
    for name, model in models().items():
        rows = {}
        rows["numpy estimator"] = bench_numpy(model, data, args.epochs)
        rows["torch layer"] = bench_torch(model, data, args.epochs, args.torch_adam)
        if not args.skip_pennylane:
            for dev, method in (("default.qubit", "backprop"), ("lightning.qubit", "adjoint")):
                label = f"pennylane {dev} {method} (x{args.pl_batches}b)"
                try:
                    sec, acc, mismatch = bench_pennylane(model, data, dev, method,
                                                         args.pl_batches, args.torch_adam)
                    rows[label] = (sec, acc)
                    print(f"{name:<8} {label}: max |f_PennyLane - f_qdensity| = {mismatch:.1e} "
                          f"(same circuits); its test accuracy is after {args.pl_batches} "
                          f"batches only")
                except Exception as exc:  # noqa: BLE001 - report and go on
                    print(f"{name:<8} {label:<34} failed: {type(exc).__name__}: {exc}")
        base = rows["numpy estimator"][0]
        for label, (sec, acc) in rows.items():
            print(f"{name:<8} {label:<34} {sec:>9.3f} {acc:>9.3f} {sec / base:>8.2f}x")
        pl = [sec for label, (sec, _) in rows.items() if label.startswith("pennylane")]
        if pl:
            best = min(pl)
            print(f"{name:<8} torch / numpy = {rows['torch layer'][0] / base:.2f}; best PennyLane "
                  f"/ numpy = {best / base:.1f}x, / torch = {best / rows['torch layer'][0]:.1f}x")
        print()


if __name__ == "__main__":
    main()
