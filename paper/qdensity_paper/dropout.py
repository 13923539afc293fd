"""``dropout``: the paper's dropout protocol for density QNNs, run in its overfitting setting
("Quantum dropout"; Supp. "Dropout interpretation of density QNNs"; the data of Fig. 6b and
Supp. J).

The paper proposes, without running it, to train a density QNN with the randomised preparation
(Fig. 1c: one sub-unitary sampled per shot, the others dropped out) and to predict with the
deterministic one (Fig. 1b: the mixture itself), as dropout trains sub-networks and predicts
with their average. This experiment runs that protocol
(:class:`~qdensity.models.dropout.QuantumDropout`) on Supp. J's re-uploading task (``T_2`` with
noise std 0.2, ``R_y(x) R_x(x)`` uploads, 25 training points) and compares three models per seed:

* ``vanilla``: one circuit of ``L`` layers, trained exactly;
* ``exact``: the density QNN of ``K`` sub-unitaries of ``D = L / K`` layers, trained on the exact
  mixture's loss;
* ``dropout``: the same density QNN from the same initialisation and batch order, trained from
  shots of the randomised preparation (``shots`` per data point for each estimate) and scored
  with the deterministic prediction.

Each model reports train / test MSE of its (deterministic) prediction, their gap, and the shots
its training drew.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from qdensity.datasets.chebyshev import chebyshev_split
from qdensity.execution import ShotLedger
from qdensity.learning.optim import Adam
from qdensity.models.dropout import QuantumDropout
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity_paper._common import curve, figure_name, plot_curves
from qdensity_paper.protocol import Departure, PaperProtocol
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult
from qdensity_paper.reuploading import SETTINGS, density_depth

__all__ = ["EXPERIMENT", "MODELS", "run_seed", "plot"]

#: The three models, in plotting order.
MODELS = ("vanilla", "exact", "dropout")

_LABELS = {"vanilla": "vanilla re-uploading", "exact": "density, exact training",
           "dropout": "density, dropout training"}


def _check(config: dict) -> dict:
    cfg = dict(config)
    if cfg["setting"] not in SETTINGS:
        raise ValueError(f"setting must be one of {sorted(SETTINGS)}, got {cfg['setting']!r}")
    for key, low in (("layers", 1), ("experts", 2), ("epochs", 1), ("batch_size", 1),
                     ("num_train", 1), ("num_test", 2), ("shots", 1), ("curve_points", 1)):
        v = cfg[key]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ValueError(f"{key} must be an int >= {low}, got {v!r}")
    lr = cfg["learning_rate"]
    if isinstance(lr, bool) or not isinstance(lr, (int, float)) or not 0 < lr < 10:
        raise ValueError(f"learning_rate must be a number in (0, 10), got {lr!r}")
    return cfg


def _fit(name: str, model: SingleQubitReuploading, data, cfg: dict, seed: int) -> dict:
    """Adam over shuffled batches; the dropout model's gradients from shots (seeded per step)."""
    X_tr, X_te, y_tr, y_te = data
    ledger = ShotLedger()
    drop = QuantumDropout(model, shots=int(cfg["shots"])) if name == "dropout" else None
    order_rng = np.random.default_rng([seed, 7])  # the same batch order for every model
    shot_rng = np.random.default_rng([seed, 11])
    opt, p = Adam(lr=float(cfg["learning_rate"])), model.get_params()
    epochs, bs = int(cfg["epochs"]), int(cfg["batch_size"])
    every = max(1, epochs // int(cfg["curve_points"]))
    hist: dict[str, list] = {"epoch": [], "train": [], "test": []}
    for epoch in range(1, epochs + 1):
        order = order_rng.permutation(len(y_tr))
        for start in range(0, len(order), bs):
            idx = order[start:start + bs]
            if drop is None:
                _, grad = model.loss_and_grad(X_tr[idx], y_tr[idx])
            else:
                _, grad = drop.train().loss_and_grad(X_tr[idx], y_tr[idx], seed=shot_rng,
                                                     ledger=ledger)
            p = opt.step(p, grad)
            model.set_params(p)
        if epoch % every == 0 or epoch == epochs:
            hist["epoch"].append(epoch)
            hist["train"].append(model.mse(X_tr, y_tr))
            hist["test"].append(model.mse(X_te, y_te))
    train, test = model.mse(X_tr, y_tr), model.mse(X_te, y_te)
    out: dict[str, Any] = {f"{name}/train_mse": train, f"{name}/test_mse": test,
                           f"{name}/gap": test - train,
                           f"{name}/parameters": model.num_circuit_parameters,
                           f"{name}/training_shots": float(ledger.total_shots)}
    out["curves"] = {f"{name}/test_vs_epoch": curve(hist["epoch"], hist["test"], "epoch",
                                                    "test MSE (deterministic prediction)"),
                     f"{name}/train_vs_epoch": curve(hist["epoch"], hist["train"], "epoch",
                                                     "train MSE (deterministic prediction)")}
    return out


def run_seed(config: dict, seed: int, progress: bool = False) -> dict:
    """One seed: data, then the vanilla, exact-trained and dropout-trained models.

    Returns
    -------
    dict
        ``m/train_mse``, ``m/test_mse``, ``m/gap``, ``m/parameters``, ``m/training_shots`` for
        ``m`` in :data:`MODELS`, and test / train MSE curves against epochs.
    """
    cfg = _check(config)
    degree, noise, encoding = SETTINGS[cfg["setting"]]
    data = chebyshev_split(degree, noise, num_train=int(cfg["num_train"]),
                           num_test=int(cfg["num_test"]), seed=seed)
    L, K = int(cfg["layers"]), int(cfg["experts"])
    out: dict = {"curves": {}}
    for name in MODELS:
        layers, subs = (L, 1) if name == "vanilla" else (density_depth(L, K), K)
        init = np.random.default_rng([seed, 0 if name == "vanilla" else 1])
        model = SingleQubitReuploading(layers, subs, encoding=encoding, seed=init)
        part = _fit(name, model, data, cfg, seed)
        out["curves"].update(part.pop("curves"))
        out.update(part)
    return out


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Test and train MSE of the three models against epochs (mean over the seeds)."""
    n = len(result.seeds)
    labels = {f"{m}/{k}_vs_epoch": _LABELS[m] for m in MODELS for k in ("test", "train")}
    path = plot_curves(result, [("test MSE", [f"{m}/test_vs_epoch" for m in MODELS]),
                                ("train MSE", [f"{m}/train_vs_epoch" for m in MODELS])],
                       Path(directory) / figure_name(result, "dropout.png"),
                       title="Dropout protocol (our extension) on Supp. J's T_2 task",
                       mode="the paper's settings" if result.mode == "full" else None,
                       labels=labels,
                       y_labels=[f"test MSE, mean of {n} seeds",
                                 f"train MSE, mean of {n} seeds"])
    return [path]


_SUPP_J = {"setting": "supp_j", "layers": 50, "experts": 5, "epochs": 300, "batch_size": 5,
           "learning_rate": 0.001, "num_train": 25, "num_test": 110, "shots": 100,
           "curve_points": 30}

PAPER = PaperProtocol(
    settings=dict(_SUPP_J),
    fixed=("setting", "layers", "experts", "batch_size", "learning_rate", "num_train",
           "num_test"),
    readings={"epochs": "not stated; 300, as the reuploading experiment",
              "shots": "not stated: 100 shots per data point for each estimate (forward, "
                       "mixture gradient, each parameter-shift pair)",
              "curve_points": "how often the curves are scored (no effect on training)"},
    departures=(Departure("the paper proposes the dropout protocol and runs no numerics for it: "
                          "this mode runs it in Supp. J's overfitting setting (T_2, K = 5, "
                          "L = 50, batch 5, Adam 1e-3)"),),
    source="'Quantum dropout' and Supp. 'Dropout interpretation of density QNNs' (the "
           "protocol); Supp. J (the setting)")

EXPERIMENT = Experiment(
    name="dropout",
    title="density QNN trained by the randomised preparation (dropout) and predicting with the "
          "deterministic one, against exact training and the vanilla re-uploading model",
    paper="'Quantum dropout' (Results), Supp. 'Dropout interpretation of density QNNs', Fig. 1b-c; "
          "setting of Fig. 6b / Supp. J",
    quick={**_SUPP_J, "layers": 4, "experts": 2, "epochs": 3, "num_train": 10, "num_test": 20,
           "shots": 20, "curve_points": 3},
    full=dict(_SUPP_J),
    run_seed=run_seed,
    plot=plot,
    seeds={"quick": 2, "full": 6, "paper": 6},
    protocol=PAPER,
    reductions="none: the full size is the paper-protocol setting (Supp. J's), 6 seeds.",
)
