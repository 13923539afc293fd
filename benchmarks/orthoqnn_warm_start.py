"""The dip at the warm start of ``orthoqnn-depth`` (paper Fig. 7, epoch 26): what causes it.

At the end of pretraining (epoch ``pretrain_epochs``) the experiment's density curve carries
the *mean* test accuracy of the K pretrained sub-models. The density model then starts from
their angles with the MoE gate at W = 0, b = 0 (alpha = 1/K for every x) and the *mean* of
their K linear read-outs, so before any step it predicts

    argmax_c [ W_bar (1/K sum_k p_k(x)) + b_bar ]_c,   W_bar = mean_k W_k, b_bar = mean_k b_k,

where ``p_k(x)`` are sub-model k's unary probabilities (the paper's Fig. 6 density state read
out; eq. 3). That is not any sub-model's classifier: ``W_j p_k`` for ``j != k`` applies a
read-out trained on another sub-unitary's features. Hypothesis: this warm-start point is
below the epoch-25 point, and the epoch-26 point (after one epoch of Adam on the density
model) is phase 2 climbing back from it, not the optimiser pulling a good start down.

For each seed this script reproduces the experiment's seed stream for one depth (pure model's
seeds drawn and skipped, as ``run_seed`` does), pretrains the K sub-models, and prints

* ``mean_sub`` / ``best_sub``: the epoch-25 point (mean sub-model accuracy) and the best one;
* ``warm_start``: the accuracy before any phase-2 step, computed here by hand in numpy from
  each sub-model's exact probabilities (not by the density model's forward pass);
* ``engine``: the same accuracy from the warm-started density model's own exact forward (a
  cross-check of the line above);
* ``logit_mean``: the ensemble that averages the sub-models' logits ``W_k p_k + b_k`` (what
  "the mean of their read-outs" would be if each kept its own);
* phase-2 test accuracy after 1, 2, ... ``epochs`` epochs for two warm starts: ``mean`` (the
  experiment's) and ``best`` (gate bias putting 0.99 on the best sub-model, 0.01 spread on
  the others, and the best sub-model's read-out), each with a fresh Adam.

Rerun (from the repository root, with the package importable; 15-30 CPU-seconds per seed and
depth with 3 phase-2 epochs, 25-35 with 25; the findings are in EXPERIMENTS.md, orthoqnn-depth)::

    python benchmarks/orthoqnn_warm_start.py --seeds 0 1 2 --depth 1 --epochs 3
"""

from __future__ import annotations

import argparse
import json
import resource
import sys

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.learning.nn import Linear
from qdensity.models.decompositions import cyclic_moments
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import GatedMixture
from qdensity.models.warm_start import warm_start
from qdensity_paper import orthoqnn_depth as od
from qdensity_paper._ortho_data import load_data


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _linear(post) -> tuple[np.ndarray, np.ndarray]:
    """(W, b) of a Linear read-out ``y = x W + b``: W of shape (n, classes), b (classes,)."""
    return (np.asarray(post.params["W"], dtype=float),
            np.asarray(post.params["b"], dtype=float))


def one_seed(config: dict, seed: int, depth: int, epochs: int) -> dict:
    n = int(config["num_qubits"])
    e1 = int(config["pretrain_epochs"])
    X_tr, X_te, y_tr, y_te = data = load_data(config, seed, n)
    seeds = iter(np.random.default_rng(seed).integers(0, 2**31 - 1, size=10_000).tolist())
    next(seeds), next(seeds)  # the pure model's
    enc = Encoding.unary(n)
    for d in config["depths"]:
        dec = cyclic_moments(round_robin(n), int(d))
        if d == depth:
            break
        for _ in range(2 * dec.num_subunitaries + 1):
            next(seeds)
    subs = []
    for circuit in dec.sub_unitaries:
        sub = DensityQNN([circuit], encoding=enc, readout="unary_probabilities",
                         seed=next(seeds))
        subs.append(od._fit(sub, data, e1, config, next(seeds), False))
    dens_seed = next(seeds)
    K = len(subs)
    sub_acc = np.array([od._accuracies(c)[-1] for c in subs])
    # by hand: each sub-model's exact unary probabilities, mixed uniformly, mean read-out
    P = np.stack([c.model_.predict(X_te) for c in subs])  # (K, N, n)
    Wb = [_linear(c.post_) for c in subs]
    classes = subs[0].classes_
    W_bar = np.mean([w for w, _ in Wb], axis=0)
    b_bar = np.mean([b for _, b in Wb], axis=0)
    warm = float(np.mean(classes[np.argmax(P.mean(axis=0) @ W_bar + b_bar, axis=1)] == y_te))
    logit_mean = np.mean([P[k] @ Wb[k][0] + Wb[k][1] for k in range(K)], axis=0)
    ens = float(np.mean(classes[np.argmax(logit_mean, axis=1)] == y_te))

    out = {"seed": seed, "depth": depth, "K": K, "mean_sub": float(sub_acc.mean()),
           "best_sub": float(sub_acc.max()), "warm_start": warm, "logit_mean": ens}
    best = int(np.argmax(sub_acc))
    for variant in ("mean", "best"):
        dens = warm_start([c.model_ for c in subs], np.full(K, 1.0 / K))
        if variant == "mean":
            bias = np.zeros(K)
            post = od._mean_post(subs, n)
        else:
            alpha = np.full(K, 0.01 / (K - 1))
            alpha[best] = 0.99
            bias = np.log(alpha)
            post = Linear(n, classes.size, seed=0)
            for key in post.params:
                post.params[key][...] = subs[best].post_.params[key]
        dens.mixture = GatedMixture(n, K, weights=np.zeros((K, n)), bias=bias)
        # the start itself through the density model's own forward (no step taken)
        logits = post.forward(dens.predict(X_te))
        out[f"{variant}/start"] = float(np.mean(classes[np.argmax(logits, axis=1)] == y_te))
        clf = od._fit(dens, data, epochs, config, dens_seed, False, post=post)
        out[f"{variant}/epochs"] = od._accuracies(clf)
    out["engine"] = out.pop("mean/start")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--depth", type=int, default=1)
    ap.add_argument("--epochs", type=int, default=3, help="phase-2 epochs per warm start")
    args = ap.parse_args(argv)
    config = dict(od.PAPER.settings)
    for seed in args.seeds:
        t = _cpu()
        row = one_seed(config, seed, args.depth, args.epochs)
        row["cpu_s"] = round(_cpu() - t, 1)
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
