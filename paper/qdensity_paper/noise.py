"""``noise``: pure vs density QNNs at equal shot budgets on a noisy device (beyond the paper).

The paper trains on noiseless simulators; its argument for density QNNs is a training-cost one
(Table 1: ``n - 1`` commuting-generator circuits per gradient instead of ``4 n (n - 1) / 2``
parameter-shift circuits, Numerical results) plus shallower circuits (each sub-unitary is one
moment of the round-robin OrthoQNN, Fig. 3 and 6). This experiment asks what survives on a
calibrated noisy device (issue 14 item 5):

1. Both models are trained on 4-class digits (PCA to ``n`` features, unary amplitude
   encoding, a classical ``n -> classes`` linear read-out, as the demo) with *sampled*
   gradient circuits on the noisy device (parameter shift for the pure round-robin OrthoQNN,
   commuting generators for its layer-by-layer density version), each with the same budget of
   training shots.
2. Along training, at equal training shots, the test accuracy is scored five ways: ``exact``
   (the trained parameters on a noiseless simulator: what the training achieved) and as the
   device would estimate it from ``eval_shots`` shots per test point (split over the
   sub-unitaries in proportion to alpha): ``raw`` counts, Hamming-weight-1 post-selection
   (``ps``), mthree readout mitigation (``m3``) and both (``m3_ps``),
   :mod:`qdensity_paper._noise_device`.
3. After training, the same scores against the shots per test point (``eval_shots_sweep``),
   the mean L1 error of each estimate of ``f(x)`` against the exact output, the weight kept in
   the Hamming-weight-1 subspace, mthree's overhead, the readout-calibration shots and the
   compiled two-qubit gate counts; and, as the reference, each model trained exactly
   (noiseless, exact gradients, ``ceiling_epochs``).

Training uses the raw sampled outputs (neither post-selected nor mitigated); the corrections
are applied to the predictions only. Calibration and evaluation shots are not part of the
training budget (reported separately). The default target is the 5-qubit ``fake_manila``
snapshot (needs ``pip install 'qdensity[ibm]'``); ``target="heavy_hex"`` (a seeded
``GenericBackendV2``, core only) also works, and so does the path of a snapshot file written by
:func:`qdensity.hardware.save_snapshot` (``--set target=PATH.json``: a paper pins the device it
ran on; the config keeps the path, each seed's ``device`` the saved device's name);
``mitigation=False`` drops mthree.
Simulation uses Aer's density-matrix method (exact noise, ~6 ms per circuit row at 5 qubits;
trajectories were 30x slower).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.datasets.digits import load_digits_features
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.execution.samplers import target_sampler
from qdensity.hardware.snapshot_files import is_snapshot_path, load_snapshot
from qdensity.hardware.snapshots import is_snapshot_name, snapshots_available
from qdensity.hardware.targets import get_target
from qdensity.learning.estimators import QNNClassifier
from qdensity.learning.nn import Linear
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.mixtures import SoftmaxMixture
from qdensity_paper._common import curve, curve_colours, plot_curves
from qdensity_paper._noise_device import VARIANTS, DeviceOutputs, device_outputs
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult

__all__ = ["EXPERIMENT", "run_seed", "plot", "check_config"]

MODELS = (("pure", "shift"), ("density", "commuting"))
SCORES = ("exact",) + VARIANTS
LABELS = {"exact": "exact (noiseless)", "raw": "device, raw", "ps": "device, HW-1 post-sel.",
          "m3": "device, mthree", "m3_ps": "device, mthree + post-sel."}

QUICK = {"target": "fake_manila", "num_qubits": 4, "classes": 4, "train_size": 200,
         "test_size": 16, "shots": 8, "budget": 1600, "batch_size": 2,
         "learning_rate": 0.1, "checkpoints": 2, "eval_shots": 64,
         "eval_shots_sweep": [16, 256], "mitigation": "auto", "calibration_shots": 500,
         "ceiling_epochs": 1}
FULL = {"target": "fake_manila", "num_qubits": 5, "classes": 4, "train_size": None,
        "test_size": 120, "shots": 32, "budget": 600_000, "batch_size": 4,
        "learning_rate": 0.1, "checkpoints": 6, "eval_shots": 512,
        "eval_shots_sweep": [32, 128, 512, 2048, 8192], "mitigation": "auto",
        "calibration_shots": 4000, "ceiling_epochs": 10}

_INSTALL = "pip install 'qdensity[ibm]'"


def _have_mthree() -> bool:
    return importlib.util.find_spec("mthree") is not None


def _positive_int(config: dict, key: str, minimum: int = 1) -> int:
    v = config[key]
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise ValueError(f"setting {key!r} must be an int >= {minimum}, got {v!r}")
    return int(v)


def check_config(config: dict) -> dict:
    """Validate the settings of the ``noise`` experiment (see ``QUICK`` / ``FULL``).

    Raises
    ------
    ValueError
        A setting out of range, naming it.
    ImportError
        A device snapshot target (``fake_*``) without ``qiskit-ibm-runtime``, or
        ``mitigation=True`` without ``mthree``; the message says ``pip install 'qdensity[ibm]'``.
    """
    c = dict(config)
    if isinstance(c["target"], os.PathLike):
        c["target"] = os.fspath(c["target"])  # the JSON config keeps the path as a string
    if not isinstance(c["target"], str) or c["target"] in ("ideal",):
        raise ValueError(f"setting 'target' must name a noisy target (a snapshot such as "
                         f"'fake_manila', 'heavy_hex', 'line', ..., or the path of a snapshot "
                         f"file written by qdensity.hardware.save_snapshot), got "
                         f"{c['target']!r}")
    if is_snapshot_path(c["target"]):
        try:  # a missing, foreign or newer file is refused here, before any data or training
            load_snapshot(c["target"])
        except ValueError as exc:
            raise ValueError(f"setting 'target': {exc}") from None
    elif is_snapshot_name(c["target"]) and not snapshots_available():
        raise ImportError(f"target {c['target']!r} is a calibrated device snapshot from "
                          f"qiskit-ibm-runtime; install the extra: {_INSTALL}, or use a "
                          "generic noisy device, which needs no extra: qdensity experiment "
                          "noise --set target=heavy_hex (in Python: config={'target': "
                          "'heavy_hex'})")
    if c["mitigation"] == "auto":  # mthree's readout mitigation when installed, else none
        c["mitigation"] = _have_mthree()
    if not isinstance(c["mitigation"], bool):
        raise ValueError(f"setting 'mitigation' must be a bool or 'auto', got "
                         f"{c['mitigation']!r}")
    if c["mitigation"] and not _have_mthree():
        raise ImportError(f"readout mitigation needs mthree; install the extra: {_INSTALL} "
                          "(or --set mitigation=false; the default 'auto' uses mthree only "
                          "when it is installed)")
    n = _positive_int(c, "num_qubits", 3)
    if n > 6:
        raise ValueError(f"setting 'num_qubits' must be 3..6 (dense outcome counts and "
                         f"density-matrix simulation), got {n}")
    classes = _positive_int(c, "classes", 2)
    if classes > 10:
        raise ValueError(f"setting 'classes' must be 2..10 (digits), got {classes}")
    if c["train_size"] is not None:
        _positive_int(c, "train_size", classes)
    _positive_int(c, "test_size", 1)
    for key in ("shots", "budget", "batch_size", "checkpoints", "calibration_shots"):
        _positive_int(c, key)
    _positive_int(c, "ceiling_epochs", 0)
    _positive_int(c, "eval_shots", n)
    sweep = c["eval_shots_sweep"]
    if not isinstance(sweep, (list, tuple)) or not sweep:
        raise ValueError(f"setting 'eval_shots_sweep' must be a non-empty list of ints, got "
                         f"{sweep!r}")
    for s in sweep:
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < n:
            raise ValueError(f"setting 'eval_shots_sweep' must hold ints >= num_qubits = {n} "
                             f"(at least one shot per sub-unitary), got {s!r}")
    lr = c["learning_rate"]
    if isinstance(lr, bool) or not isinstance(lr, (int, float)) or not lr > 0:
        raise ValueError(f"setting 'learning_rate' must be a positive number, got {lr!r}")
    return c


def _data(c: dict, seed: int):
    X_tr, X_te, y_tr, y_te = load_digits_features(c["num_qubits"], 300, seed)
    rng = np.random.default_rng(seed)
    keep_tr = np.flatnonzero(y_tr < c["classes"])
    keep_te = np.flatnonzero(y_te < c["classes"])
    if c["train_size"] is not None and c["train_size"] < keep_tr.size:
        keep_tr = np.sort(rng.choice(keep_tr, c["train_size"], replace=False))
    if c["test_size"] > keep_te.size:
        raise ValueError(f"setting 'test_size' must be at most {keep_te.size} for "
                         f"{c['classes']} classes, got {c['test_size']}")
    keep_te = np.sort(rng.choice(keep_te, c["test_size"], replace=False))
    return X_tr[keep_tr], X_te[keep_te], y_tr[keep_tr], y_te[keep_te]


def _models(n: int, seed: int):
    enc = Encoding.unary(n)
    pure = DensityQNN([round_robin(n)], encoding=enc, readout="unary_probabilities", seed=seed)
    dec = by_moments(round_robin(n))
    dens = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), encoding=enc,
                      readout="unary_probabilities")
    dens.set_params(theta=pure.theta)  # the same angles: the pure circuit cut into layers
    return {"pure": pure, "density": dens}


def _scores(est, X, y, engine, shots) -> tuple[dict, DeviceOutputs, np.ndarray]:
    """Test accuracy exact and four device ways, the device outputs and the exact outputs."""
    dev = device_outputs(est.model_, X, engine=engine, shots=shots)
    exact = est.model_.predict(X)
    acc = {"exact": float(est.score(X, y))}
    for name, out in dev.values.items():
        logits = est.post_.forward(out)
        acc[name] = float(np.mean(est.classes_[logits.argmax(axis=1)] == y))
    return acc, dev, exact


def _sim_engine(target, seed: int, progress: bool = False, mitigation: str | None = None,
                calibration_shots: int = 4000) -> SamplerEngine:
    sampler = target_sampler(target, seed=seed, method="density_matrix")
    return SamplerEngine(sampler, target=target, seed=seed, progress=progress,
                         mitigation=mitigation, calibration_shots=calibration_shots)


def run_seed(config: dict, seed: int, progress: bool = False) -> dict:
    """One seed: train both models on the noisy device, score them five ways.

    Parameters
    ----------
    config : dict
        Settings (``QUICK`` / ``FULL`` keys).
    seed : int
        Seeds the data split, the device (its noise for ``heavy_hex``, transpilation and
        sampling), initial parameters and batch order.
    progress : bool
        Training progress bars.

    Returns
    -------
    dict
        Scalars per model (``pure/...``, ``density/...``) and the curves (see the module
        docstring).
    """
    c = check_config(config)
    n, seed = c["num_qubits"], int(seed)
    X_tr, X_te, y_tr, y_te = _data(c, seed)
    fixed = is_snapshot_name(c["target"]) or is_snapshot_path(c["target"])
    target = get_target(c["target"], None if fixed else n, seed=seed)
    if target.num_qubits < n:
        raise ValueError(f"setting 'num_qubits' ({n}) is wider than target {c['target']!r} "
                         f"({target.num_qubits} qubits)")
    evaluator = _sim_engine(target, seed + 1, mitigation="m3" if c["mitigation"] else None,
                            calibration_shots=c["calibration_shots"])
    scores = SCORES if c["mitigation"] else SCORES[:3]
    out: dict = {"curves": {}}
    curves = out["curves"]
    for name, model in _models(n, seed).items():
        method = dict(MODELS)[name]
        points: list[tuple[int, dict]] = []
        marks = [c["budget"] * i / c["checkpoints"] for i in range(1, c["checkpoints"])]

        def checkpoint(est, step, points=points, marks=marks):
            spent = est.layer_.shots_spent
            if step == 0 or (marks and spent >= marks[0]):
                while marks and spent >= marks[0]:
                    marks.pop(0)
                acc = _scores(est, X_te, y_te, evaluator, c["eval_shots"])[0]
                points.append((spent, acc))

        engine = _sim_engine(target, seed)
        clf = QNNClassifier(model, post=Linear(n, c["classes"], seed=seed),
                            learning_rate=c["learning_rate"], epochs=10_000,
                            batch_size=c["batch_size"], engine=engine, shots=c["shots"],
                            gradient=method, seed=seed, verbose=progress,
                            max_shots=c["budget"], callback=checkpoint)
        clf.fit(X_tr, y_tr)
        acc, dev, exact = _scores(clf, X_te, y_te, evaluator, c["eval_shots"])
        if points[-1][0] == clf.layer_.shots_spent:  # the last step was a checkpoint already
            points.pop()
        points.append((clf.layer_.shots_spent, acc))
        for s in scores:
            curves[f"{name}/{s}_vs_shots"] = curve([p for p, _ in points],
                                                   [a[s] for _, a in points],
                                                   "training shots", "test accuracy")
            out[f"{name}/{s}_accuracy"] = acc[s]
        for v in dev.values:
            out[f"{name}/{v}_output_error"] = float(np.abs(dev.values[v] - exact).sum(1).mean())
        for v, kept in dev.kept.items():
            out[f"{name}/{v}_kept_fraction"] = float(kept.mean())
        if c["mitigation"]:
            out[f"{name}/mitigation_overhead"] = float(dev.overhead.mean())
        out[f"{name}/two_qubit_gates_mean"] = float(np.mean(dev.two_qubit_gates))
        out[f"{name}/two_qubit_gates_max"] = float(np.max(dev.two_qubit_gates))
        out[f"{name}/train_shots"] = clf.layer_.shots_spent
        out[f"{name}/train_circuits"] = engine.ledger.total_circuits
        out[f"{name}/steps"] = len(clf.history_)
        sweep = [_scores(clf, X_te, y_te, evaluator, int(s))
                 for s in c["eval_shots_sweep"]]
        for s in scores:
            curves[f"{name}/{s}_vs_eval_shots"] = curve(c["eval_shots_sweep"],
                                                        [a[s] for a, _, _ in sweep],
                                                        "shots per test point", "test accuracy")
        for v in dev.values:
            curves[f"{name}/{v}_error_vs_eval_shots"] = curve(
                c["eval_shots_sweep"], [np.abs(d.values[v] - e).sum(1).mean() for _, d, e in sweep],
                "shots per test point", "mean L1 error of f(x)")
        if c["ceiling_epochs"]:
            ref = QNNClassifier(model, post=Linear(n, c["classes"], seed=seed),
                                learning_rate=c["learning_rate"], epochs=c["ceiling_epochs"],
                                batch_size=16, seed=seed, verbose=False).fit(X_tr, y_tr)
            out[f"{name}/ceiling_accuracy"] = float(ref.score(X_te, y_te))
    cal = evaluator.ledger.by_label().get("readout calibration", (0, 0))
    out["mitigation/calibration_shots"] = int(cal[1])
    out["device"] = target.name  # the device it ran on (a snapshot file's saved name)
    out["device_qubits"] = target.num_qubits
    return out


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Four figures: accuracy against training shots per model (five scores), pure vs density
    on the device and exactly, accuracy against shots per test point, and the L1 error of
    each device estimate of the model output against shots per test point."""
    directory = Path(directory)
    tgt = result.config.get("target", "")
    # one colour per method (and per model) in all four figures
    fixed = curve_colours([*(LABELS[s] for s in SCORES), *(m for m, _ in MODELS)])
    fixed.update({LABELS[v].replace("device, ", ""): fixed[LABELS[v]] for v in VARIANTS})
    labels = {f"{m}/{s}_vs_{x}": LABELS[s] for m, _ in MODELS for s in SCORES
              for x in ("shots", "eval_shots")}
    paths = [plot_curves(result, [(f"{m}: test accuracy vs training shots",
                                   [f"{m}/{s}_vs_shots" for s in SCORES]) for m, _ in MODELS],
                         directory / f"{result.name}-{result.mode}-training.png",
                         title=f"noise on {tgt}: scores along training", labels=labels,
                         colours=fixed)]
    versus = {f"{m}/{s}_vs_shots": f"{m}" for m, _ in MODELS for s in SCORES}
    paths.append(plot_curves(result, [(f"{LABELS[s]}", [f"{m}/{s}_vs_shots" for m, _ in MODELS])
                                      for s in ("exact", "raw", "m3_ps")],
                             directory / f"{result.name}-{result.mode}-pure-vs-density.png",
                             title=f"noise on {tgt}: pure vs density at equal training shots",
                             labels=versus, colours=fixed))
    paths.append(plot_curves(result, [(f"{m}: after training",
                                       [f"{m}/{s}_vs_eval_shots" for s in SCORES])
                                      for m, _ in MODELS],
                             directory / f"{result.name}-{result.mode}-eval-shots.png",
                             title=f"noise on {tgt}: accuracy vs shots per prediction",
                             labels=labels, log_x=(True, True), colours=fixed))
    errors = {f"{m}/{v}_error_vs_eval_shots": LABELS[v].replace("device, ", "")
              for m, _ in MODELS for v in VARIANTS}
    paths.append(plot_curves(result, [(f"{m}: device output vs exact output",
                                       [f"{m}/{v}_error_vs_eval_shots" for v in VARIANTS])
                                      for m, _ in MODELS],
                             directory / f"{result.name}-{result.mode}-output-error.png",
                             title=f"noise on {tgt}: error of the estimated model output",
                             labels=errors, log_x=(True, True), colours=fixed))
    return paths


EXPERIMENT = Experiment(
    name="noise",
    title="pure vs density QNN at equal shot budgets on a noisy device snapshot, with and "
          "without Hamming-weight-1 post-selection and mthree readout mitigation",
    paper="beyond the paper (a noisy device at equal shot budgets); models of Fig. 3 / 6 and "
          "Table 1",
    quick=QUICK,
    full=FULL,
    run_seed=run_seed,
    plot=plot,
    seeds={"quick": 2, "full": 5},
    reductions="beyond the paper, so no protocol to reduce; chosen for 2-core budgets: 5 qubits "
               "(the fake_manila device), 4-class digits (PCA to 5 features; 10 classes have an "
               "exact ceiling near 0.5 on 5 qubits), 600k training shots per model (pure: ~114 "
               "steps of batch 4, density: ~468), 120 test digits, exact-training ceiling after "
               "10 epochs. Training uses raw sampled outputs; post-selection and mitigation are "
               "applied to the predictions only, and their shots are not in the budget.",
)
