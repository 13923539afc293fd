"""``qdensity experiment equivariant``: equivariant QNNs and their density versions on noisy bars
and dots (paper Fig. 5, Sec. "Equivariant quantum neural networks", Methods "Equivariant
density QNN").

For each family of Bowles et al. (commuting XX, non-commuting, QCNN; see
:mod:`qdensity_paper._equivariant_models`):

1. the base model ``U_1`` is trained for ``pretrain_steps`` and then ``density_steps`` more
   (its curve covers both);
2. the second sub-unitary ``U_2`` (YY for the XX family, an independent copy otherwise) is
   trained on its own for ``pretrain_steps``;
3. the density model ``alpha_1 U_1 + alpha_2 U_2`` starts from ``U_1`` at ``pretrain_steps``
   and the trained ``U_2`` (:func:`qdensity.models.warm_start`, trainable softmax alpha from
   ``(0.99, 0.01)``, ``U_1``'s read-out head) and trains ``density_steps``.

Training is exact (adjoint statevector engine). Shots are counted as on hardware, as in
Bowles et al.'s code that the paper adapts: ``circuits_per_row x batch_size x
shots_per_circuit`` per step (1000 shots per circuit there), ``circuits_per_row`` read off
the model's gradient plan (:func:`gradient_circuits`: commuting-generator circuits for XX / YY,
parameter shift for the non-commuting circuit and the QCNN, as Bowles et al. count, plus one
forward circuit per sub-unitary; a density model needs the sum over its sub-unitaries). The density
curve's shots start after the base model's pre-training shots plus ``U_2``'s (the gap of the
paper's Fig. 5b).

Encoding: ``R_y(angle_scale x_i)`` on qubit ``i``. The paper's Methods write ``R_y(pi x_i / 2)``
(``angle_scale = pi / 2``); Bowles et al.'s code, which the paper adapts, rescales the data by
0.5 into ``R_y(x)`` (``angle_scale = 0.5``, our default). At ``sigma = 1.8`` the paper's literal
scale washes the signal out: ``E[sin(pi (s + e) / 2)] = sin(pi s / 2) exp(-pi^2 sigma^2 / 8)``,
about 0.02 for ``s = +-1``, and a logistic regression on the translation-invariant correlations
of ``sin(pi x_i / 2)`` (what these models read) scores 0.50 on 2000 test points, against 0.76
at scale 0.5.

One "epoch" of the paper's Fig. 5 is one Adam step on a mini-batch of 20 (Bowles et al.'s
iteration); test accuracy is scored on the test set every ``eval_every`` steps.

Read-out (``readout``): ``"sum_z"`` (``--paper``) trains the paper's ``f = sum_i <Z_i>`` itself
with the adapted code's square loss against the +-1 labels and predicts its sign; ``"head"``
(``--quick``, ``--full``) puts a trained linear head with cross entropy on it (the density model
keeps the base model's head). ``same_initialisation`` (``--paper``): every run (seed) uses one
data set and one set of initial angles, drawn from seed 0, and differs only in batch order, as
Fig. 5's "5 independent training runs, from the same initialisation".
"""

from __future__ import annotations

import functools
import numbers
from pathlib import Path

import numpy as np

from qdensity.datasets.bars_and_dots import bars_and_dots
from qdensity.models.warm_start import warm_start
from qdensity.validation import SeedLike, as_rng
from qdensity_paper._accounting import breakdown_metrics
from qdensity_paper._common import circuits_per_row, curve, figure_name, plot_curves
from qdensity_paper._equivariant_models import (
    FAMILIES,
    LABELS,
    single_model,
    train_recorded,
)
from qdensity_paper.protocol import Departure, PaperProtocol
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult

__all__ = ["EXPERIMENT", "run_seed", "plot", "check_config", "gradient_circuits"]

_INTS = {"num_qubits": 4, "train_size": 2, "test_size": 1, "batch_size": 1,
         "pretrain_steps": 1, "density_steps": 1, "eval_every": 1, "shots_per_circuit": 1,
         "max_weight": 1, "layers": 1, "tail": 1}


def check_config(config: dict) -> dict:
    """Validate the settings; raise ValueError naming the bad one."""
    for key, low in _INTS.items():
        v = config[key]
        if isinstance(v, bool) or not isinstance(v, numbers.Integral) or v < low:
            raise ValueError(f"setting {key!r} must be an int >= {low}, got {v!r}")
    for key in ("noise_std", "learning_rate", "angle_scale"):
        v = config[key]
        strict = key != "noise_std"
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not np.isfinite(float(v)) or (
                v < 0 or (strict and v == 0)):
            raise ValueError(f"setting {key!r} must be a finite number "
                             f"{'> 0' if strict else '>= 0'}, got {v!r}")
    if config.get("readout", "head") not in ("head", "sum_z"):
        raise ValueError(f"setting 'readout' must be 'head' or 'sum_z', got "
                         f"{config['readout']!r}")
    if not isinstance(config.get("same_initialisation", False), bool):
        raise ValueError(f"setting 'same_initialisation' must be true or false, got "
                         f"{config['same_initialisation']!r}")
    fams = config["families"]
    if isinstance(fams, str) or not fams or any(f not in FAMILIES for f in fams) or len(
            set(fams)) != len(fams):
        raise ValueError(f"setting 'families' must be a non-empty list of distinct names from "
                         f"{list(FAMILIES)}, got {fams!r}")
    a = config["alpha_init"]
    if (not isinstance(a, (list, tuple)) or len(a) != 2
            or any(isinstance(v, bool) or not isinstance(v, numbers.Real) or v <= 0 for v in a)
            or abs(sum(a) - 1) > 1e-9):
        raise ValueError(f"setting 'alpha_init' must be two positive weights summing to 1, got "
                         f"{a!r}")
    if config["max_weight"] > config["num_qubits"]:
        raise ValueError(f"setting 'max_weight' must be <= num_qubits ({config['num_qubits']}), "
                         f"got {config['max_weight']}")
    if config["batch_size"] > config["train_size"]:
        raise ValueError(f"setting 'batch_size' must be <= train_size ({config['train_size']}), "
                         f"got {config['batch_size']}")
    if config["tail"] > 1 + config["density_steps"] // config["eval_every"]:
        raise ValueError("setting 'tail' (evaluations averaged at the end) exceeds the "
                         "evaluations of the density phase")
    return config


@functools.lru_cache(maxsize=64)
def gradient_circuits(family: str, num_qubits: int, second: bool, *, max_weight: int = 3,
                      layers: int = 4) -> int:
    """Circuits per data point of one training step of ``U_1`` (or ``U_2``) alone: gradient
    circuits plus one forward circuit (:func:`~qdensity_paper._common.circuits_per_row`).

    As in Bowles et al.'s shot count that the paper uses: commuting-generator circuits for the
    XX / YY circuits, parameter shift for the non-commuting circuit and the QCNN. A density
    model of independent sub-unitaries needs the sum over its sub-unitaries (Cor. 1).
    """
    model = single_model(family, num_qubits, second, None, max_weight=max_weight,
                         layers=layers)
    method = "commuting" if family == "xx" else "shift"
    return circuits_per_row(model, np.zeros((1, num_qubits)), method)


def _data(config: dict, seed: SeedLike):
    rng = as_rng(seed)
    n, sigma = config["num_qubits"], config["noise_std"]
    X, y = bars_and_dots(config["train_size"], n, sigma, seed=rng)
    Xt, yt = bars_and_dots(config["test_size"], n, sigma, seed=rng)
    # the encoding is R_y(pi x / 2); feed x' = (2 / pi) angle_scale x so the angle is
    # angle_scale x (0.5 in Bowles et al.'s code, pi / 2 in the paper's Methods text)
    factor = 2.0 / np.pi * config["angle_scale"]
    return factor * X, y, factor * Xt, yt


def _family(family: str, config: dict, data: tuple, seeds: np.ndarray, progress: bool
            ) -> dict:
    """Train one family's base, second sub-unitary and density model; curves and metrics."""
    n, pre, post_steps = config["num_qubits"], config["pretrain_steps"], config["density_steps"]
    kw = {"max_weight": config["max_weight"], "layers": config["layers"]}
    train_kw = {"batch_size": config["batch_size"], "learning_rate": config["learning_rate"],
                "eval_every": config["eval_every"], "progress": progress}
    base_label, dens_label = LABELS[family]
    s = [int(v) for v in seeds]
    train_kw["readout"] = config.get("readout", "head")
    base0 = single_model(family, n, False, s[0], **kw)
    base = train_recorded(base0, data, pre + post_steps, seed=s[1], snapshot_at=pre, **train_kw)
    second = train_recorded(single_model(family, n, True, s[2], **kw), data, pre, seed=s[3],
                            **train_kw)
    start_model, head = base["snapshot"]
    dens_model = warm_start([start_model, second["estimator"].model_], config["alpha_init"])
    dens = train_recorded(dens_model, data, post_steps, seed=s[4],
                          post="linear" if head is None else head, **train_kw)

    per_step = config["batch_size"] * config["shots_per_circuit"]
    c_base = gradient_circuits(family, n, False, **kw)
    c_second = gradient_circuits(family, n, True, **kw)
    c_dens = c_base + c_second
    b_steps = np.array(base["steps"], dtype=float)
    d_steps = np.array(dens["steps"], dtype=float)
    b_shots = b_steps * c_base * per_step
    offset = pre * (c_base + c_second) * per_step
    d_shots = offset + d_steps * c_dens * per_step
    tail = config["tail"]
    b_final = float(np.mean(base["accuracy"][-tail:]))
    d_final = float(np.mean(dens["accuracy"][-tail:]))
    b_at_switch = base["accuracy"][base["steps"].index(pre)] if pre in base["steps"] else np.nan
    y_lab = "test accuracy"
    curves = {
        f"{base_label}/test_vs_epoch": curve(b_steps, base["accuracy"], "epoch (Adam step)",
                                             y_lab),
        f"{dens_label}/test_vs_epoch": curve(pre + d_steps, dens["accuracy"],
                                             "epoch (Adam step)", y_lab),
        # step 0 (no shots yet) has no place on the log-scaled shots axis
        f"{base_label}/test_vs_shots": curve(b_shots[b_steps > 0],
                                             np.asarray(base["accuracy"])[b_steps > 0],
                                             "shots", y_lab),
        f"{dens_label}/test_vs_shots": curve(d_shots, dens["accuracy"], "shots", y_lab),
    }
    metrics = {
        f"{family}/base_test_accuracy": b_final,
        f"{family}/density_test_accuracy": d_final,
        f"{family}/density_gain": d_final - b_final,
        f"{family}/base_test_accuracy_at_switch": float(b_at_switch),
        f"{family}/second_test_accuracy": float(second["accuracy"][-1]),
        f"{family}/density_alpha_2": float(dens["alpha"][1]),
        f"{family}/base_circuits_per_row": c_base,
        f"{family}/second_circuits_per_row": c_second,
        # the density model's count broken down (no classical layer in front of the encoding,
        # so no input gradients; no mitigation)
        **breakdown_metrics(f"{family}/density", {
            "forward": 2, "parameter_gradients": [c_base - 1, c_second - 1],
            "input_gradients": [0, 0], "per_point": c_dens, "calibration": 0}),
        f"{family}/base_shots": float(b_shots[-1]),
        f"{family}/density_shots": float(d_shots[-1]),
    }
    return {"curves": curves, "metrics": metrics}


def run_seed(config: dict, seed: int, progress: bool) -> dict:
    """One run of every family (paper Fig. 5): data, initial angles, heads and batch orders
    all drawn from ``seed``.

    Returns
    -------
    dict
        Per family ``{family}/base_test_accuracy``, ``/density_test_accuracy`` (mean of the
        last ``tail`` evaluations), ``/density_gain``, ``/density_alpha_2``, circuits per row,
        shots, and curves ``{label}/test_vs_epoch`` and ``{label}/test_vs_shots``.
    """
    config = check_config(dict(config))
    rng = as_rng(seed)
    # Fig. 5: "5 independent training runs, from the same initialisation": one data set and
    # one set of initial angles (drawn from seed 0) for every run; the runs differ in batch order
    same = bool(config.get("same_initialisation", False))
    fixed = as_rng(0) if same else rng
    data = _data(config, fixed)
    out: dict = {"curves": {}}
    for family in config["families"]:
        seeds = fixed.integers(0, 2**31 - 1, size=5)
        if same:
            order = rng.integers(0, 2**31 - 1, size=5)
            seeds = np.array([seeds[0], order[1], seeds[2], order[3], order[4]])
        res = _family(family, config, data, seeds, progress)
        out["curves"].update(res["curves"])
        out.update(res["metrics"])
    return out


def _switch_shots(result: ExperimentResult, family: str) -> float | None:
    """Shots the base model of ``family`` has spent at the switch (``pretrain_steps`` steps):
    ``pretrain_steps x circuits_per_row x batch_size x shots_per_circuit``; None where the
    file lacks the circuit count."""
    cfg = result.config
    counts = {int(m[f"{family}/base_circuits_per_row"]) for m in result.per_seed
              if f"{family}/base_circuits_per_row" in m}
    if len(counts) != 1:
        return None
    return float(cfg["pretrain_steps"] * counts.pop() * cfg["batch_size"]
                 * cfg["shots_per_circuit"])


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Two figures in the shape of the paper's Fig. 5: test accuracy against epochs (Adam
    steps) and against shots (log scale), one panel per family, base and density model.

    The base model's curve is solid up to the switch (``pretrain_steps``, where the density
    model takes ``U_1`` over) and thin and dashed after it (the base model trained on, for
    comparison at equal epochs or shots). Against shots the density curve starts only after
    the shots that pretrained ``U_2``: the span from the base model's shots at the switch to
    the density model's first point is shaded and no line crosses it (Fig. 5b: "the gaps in
    (b) are to account for the extra measurement overhead to initialise and train the second
    sub-unitaries").
    """
    fams = list(result.config["families"])
    pre = float(result.config["pretrain_steps"])
    paths = []
    for kind, log in (("epoch", False), ("shots", True)):
        panels = [(LABELS[f][0] + " family", [f"{lab}/test_vs_{kind}" for lab in LABELS[f]])
                  for f in fams]
        split, gaps = {}, {}
        for f in fams:
            base, dens = LABELS[f]
            at = pre if kind == "epoch" else _switch_shots(result, f)
            if at is None:
                continue
            split[f"{base}/test_vs_{kind}"] = at
            if kind == "shots":
                gaps[f"{dens}/test_vs_shots"] = (at, f"shots pretraining {_SECOND[f]}")
        path = Path(directory) / figure_name(result, f"equivariant-{kind}.png")
        paths.append(plot_curves(result, panels, path,
                                 title=f"equivariant: test accuracy vs {kind}",
                                 log_x=[log] * len(panels), split=split, gaps=gaps))
    return paths


#: The second sub-unitary of each family, in words (the gap of Fig. 5b is its pretraining).
_SECOND = {"xx": "U_YY", "noncommuting": "U_2", "qcnn": "U_2"}


_PAPER = {"num_qubits": 10, "noise_std": 1.8, "test_size": 100, "batch_size": 20,
          "max_weight": 3, "layers": 4, "angle_scale": 0.5, "alpha_init": [0.99, 0.01],
          "shots_per_circuit": 1000, "families": list(FAMILIES)}

PAPER = PaperProtocol(
    settings={**_PAPER, "train_size": 1000, "pretrain_steps": 1000, "density_steps": 1000,
              "eval_every": 10, "learning_rate": 0.001, "tail": 3, "readout": "sum_z",
              "same_initialisation": True},
    fixed=("num_qubits", "noise_std", "train_size", "test_size", "batch_size", "alpha_init",
           "learning_rate", "density_steps", "families", "readout", "same_initialisation"),
    readings={"angle_scale": "Methods: R_y(pi x / 2) (angle_scale=1.5708), which leaves no "
                             "learnable signal at sigma = 1.8; Bowles et al.'s code: 0.5 x "
                             "(the default here); run both",
              "pretrain_steps": "'1000 epochs' in the Methods, '500 epochs for each model' in "
                                "the shot count; 1000 here, --set pretrain_steps=500 for the "
                                "other reading"},
    departures=(
        Departure("an 'epoch' is one optimiser step of one batch of 20, as in the code the "
                  "paper adapts (Bowles et al.)"),
        Departure("read-out: a trained linear head on the model's scalar output with cross "
                  "entropy (QNNClassifier; the density model keeps the base model's head), "
                  "where the paper reads f = sum_i <Z_i> (Methods) with the adapted code's "
                  "sign and square loss: another model than the paper's", touches=("*",),
                  applies=lambda r: r.config.get("readout", "head") != "sum_z"),
        Departure("each seed draws its own data and initialisation, where Fig. 5 shows 5 runs "
                  "from the same initialisation: the mean gain is asked over initialisations "
                  "too, the same question over a wider population",
                  applies=lambda r: not r.config.get("same_initialisation", False)),
        Departure("one encoding angle per run: the adapted code's 0.5 x by default, the "
                  "Methods' pi x / 2 only with --set angle_scale=1.5708 (a second run)"),
        Departure("each model's accuracy is the mean of its last `tail` evaluations (3: the "
                  "last 30 steps), where Fig. 5 plots the curves: a smoothed final value, the "
                  "same for base and density models")),
    source="Methods 'Equivariant density QNN' (10 qubits, sigma = 1.8, 1000 / 100 points, "
           "batch 20, Adam 1e-3, alpha = (0.99, 0.01) trainable)")

EXPERIMENT = Experiment(
    name="equivariant",
    title="XX vs XX+YY density, non-commuting vs 2-sub-unitary density, QCNN vs density QCNN "
          "on noisy bars and dots",
    paper="Fig. 5 (a: test accuracy vs epochs, b: vs shots), Sec. 'Equivariant quantum neural "
          "networks', Methods 'Equivariant density QNN'",
    quick={**_PAPER, "readout": "head", "same_initialisation": False, "num_qubits": 5,
           "train_size": 60, "test_size": 40,
           "pretrain_steps": 4, "density_steps": 4, "eval_every": 2, "learning_rate": 0.01,
           "tail": 1},
    full={**_PAPER, "readout": "head", "same_initialisation": False, "train_size": 1000,
          "pretrain_steps": 100, "density_steps": 100,
          "eval_every": 10, "learning_rate": 0.02, "tail": 3},
    run_seed=run_seed,
    plot=plot,
    seeds={"quick": 2, "full": 5, "paper": 5},
    protocol=PAPER,
    reductions="Encoding angle 0.5 x (Bowles et al.'s code that the paper adapts) instead of "
               "the Methods' pi x / 2, under which sigma = 1.8 leaves no learnable signal "
               "(set angle_scale=1.5708 for the literal text). "
               "100 pre-training + 100 density Adam steps instead of the paper's 1000 + 1000 "
               "(exact 10-qubit adjoint training costs ~0.2 s per step of 20 rows and "
               "sub-unitary; the paper's protocol would take ~50 core-minutes per seed), so the "
               "learning rate is 0.02 (Bowles et al. use 0.01) instead of 0.001, which would "
               "barely move the angles in 200 steps; the QCNN is still learning at step 200. "
               "Test accuracy is scored every 10 steps (not every "
               "step); reported accuracies average the last 3 evaluations. Readout: a trained "
               "linear head on the model's scalar output with cross entropy (QNNClassifier) "
               "instead of Bowles et al.'s sign and square loss; the density model keeps the "
               "base model's head. Quick: 5 qubits, 60/40 points, 4+4 steps.",
)
