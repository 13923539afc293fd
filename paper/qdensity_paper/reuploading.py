"""``reuploading``: density QNNs mitigate overfitting in single-qubit data re-uploading (paper
Fig. 6 / "Mitigating overfitting with density QNNs", Methods "Data reuploading density QNN",
Supp. J Figs. 17-18).

Claim (Fig. 6b): at a fixed budget of ``3 L`` circuit parameters, the vanilla re-uploading model
with ``L`` layers overfits noisy Chebyshev data as ``L`` grows (test MSE and the train/test
gap grow), while a density QNN of ``K = 5`` sub-unitaries of ``D`` layers each
(``5 x 3 D ~ 3 L``) does not; Supp. J (Fig. 17): at ``L = 50`` the density model's test MSE
falls as ``K`` grows over ``{2, 7}``.

The paper describes two settings that do not agree; ``setting`` picks one (or both):

* ``"methods"`` -- Methods "Data reuploading density QNN": ``h = T_4``, training noise of
  variance 0.25 (std 0.5), one encoding rotation per upload (``V(x) = R_x(x)``, Methods eq. 10's
  Hamiltonian encoding). This is the setting of the main-text claim about ``T_4``-like data.
* ``"supp_j"`` -- Supp. J: ``h = T_2`` (the target Fig. 6's caption and Fig. 17 name), noise std
  0.2, the encoding ``R_y(x) R_x(x)`` of eq. 37 (two data rotations per upload).
* ``"t3"``, ``"t4"`` -- Supp. J's higher-degree panels (Fig. 18): ``h = T_3`` or ``T_4`` with
  Supp. J's noise and encoding (``"both"`` runs the first two; each panel runs on its own).

Both use 25 noisy training points uniform on ``[-1, 1]`` and 110 clean test points on an even
grid (Supp. J), batch 5, Adam with learning rate 0.001, trainable ``R_z R_y R_z`` per upload,
``alpha = softmax(logits)`` trainable from uniform. The paper gives no epoch count; ``epochs``
is ours. Models are simulated exactly (:class:`~qdensity.models.single_qubit.
SingleQubitReuploading`); shots are counted as a parameter-shift run would need them: per data
point and step, two circuits per angle plus one forward circuit per sub-unitary (for the
mixture gradient), ``shots_per_circuit`` each.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from qdensity.datasets.chebyshev import chebyshev_split
from qdensity.learning.optim import Adam
from qdensity.models.single_qubit import SingleQubitReuploading
from qdensity.progress import progress_bar
from qdensity_paper._accounting import breakdown_metrics
from qdensity_paper._common import curve, figure_name, plot_curves
from qdensity_paper.protocol import Departure, PaperProtocol
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult

__all__ = ["EXPERIMENT", "SETTINGS", "run_seed", "plot", "density_depth"]

#: Setting -> (Chebyshev degree, training-noise std, encoding).
SETTINGS: dict[str, tuple[int, float, str]] = {
    "methods": (4, 0.5, "rx"),
    "supp_j": (2, 0.2, "rx_ry"),
    "t3": (3, 0.2, "rx_ry"),
    "t4": (4, 0.2, "rx_ry"),
}

#: What ``setting="both"`` runs: the two readings of Fig. 6b (``"t3"``, Supp. J's T_3 panel of
#: Fig. 18, runs on its own).
BOTH = ("methods", "supp_j")


def density_depth(num_layers: int, num_subunitaries: int) -> int:
    """``D`` with ``K x 3 D ~ 3 L``: ``max(1, round(L / K))``."""
    return max(1, int(round(num_layers / num_subunitaries)))


def _int_list(value, name: str, minimum: int) -> list[int]:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        value = [value]
    if not isinstance(value, (list, tuple)) or not value or any(
            isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum
            for v in value):
        raise ValueError(f"{name} must be a non-empty list of ints >= {minimum}, got {value!r}")
    if len(set(value)) != len(value):
        raise ValueError(f"{name} must not repeat values, got {value!r}")
    return sorted(int(v) for v in value)


def _check(config: dict) -> dict:
    cfg = dict(config)
    if cfg["setting"] not in (*SETTINGS, "both"):
        raise ValueError(f"setting must be one of {[*SETTINGS, 'both']}, got {cfg['setting']!r}")
    cfg["layers"] = _int_list(cfg["layers"], "layers", 1)
    cfg["experts_at_max"] = _int_list(cfg["experts_at_max"], "experts_at_max", 2) \
        if cfg["experts_at_max"] else []
    for key, low in (("experts", 2), ("epochs", 1), ("batch_size", 1), ("num_train", 1),
                     ("num_test", 2), ("shots_per_circuit", 1), ("curve_points", 1)):
        v = cfg[key]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise ValueError(f"{key} must be an int >= {low}, got {v!r}")
    lr = cfg["learning_rate"]
    if isinstance(lr, bool) or not isinstance(lr, (int, float)) or not 0 < lr < 10:
        raise ValueError(f"learning_rate must be a number in (0, 10), got {lr!r}")
    return cfg


def _circuits_per_row(num_layers: int, num_subunitaries: int) -> int:
    """Parameter shift: 2 circuits per angle (3 per layer) plus one forward circuit per
    sub-unitary (the vanilla model's loss needs it too)."""
    return num_subunitaries * (6 * num_layers + 1)


def _train(model: SingleQubitReuploading, data, cfg: dict, rng: np.random.Generator,
           record: bool) -> dict:
    X_tr, X_te, y_tr, y_te = data
    opt = Adam(lr=float(cfg["learning_rate"]))
    p = model.get_params()
    epochs, bs = int(cfg["epochs"]), int(cfg["batch_size"])
    every = max(1, epochs // int(cfg["curve_points"]))
    shots_epoch = (_circuits_per_row(model.num_layers, model.num_subunitaries) * len(y_tr)
                   * int(cfg["shots_per_circuit"]))
    hist: dict[str, list] = {"epoch": [], "train": [], "test": [], "shots": []}
    for epoch in range(1, epochs + 1):
        order = rng.permutation(len(y_tr))
        for start in range(0, len(order), bs):
            idx = order[start:start + bs]
            _, grad = model.loss_and_grad(X_tr[idx], y_tr[idx])
            p = opt.step(p, grad)
            model.set_params(p)
        if record and (epoch % every == 0 or epoch == epochs):
            hist["epoch"].append(epoch)
            hist["train"].append(model.mse(X_tr, y_tr))
            hist["test"].append(model.mse(X_te, y_te))
            hist["shots"].append(shots_epoch * epoch)
    return {"train_mse": model.mse(X_tr, y_tr), "test_mse": model.mse(X_te, y_te),
            "shots": shots_epoch * epochs, "history": hist}


def _record(out: dict, prefix: str, res: dict, model: SingleQubitReuploading) -> None:
    params = model.num_circuit_parameters
    K, D = model.num_subunitaries, model.num_layers
    out.update(breakdown_metrics(prefix, {
        "forward": K, "parameter_gradients": [6 * D] * K, "input_gradients": [0] * K,
        "per_point": _circuits_per_row(D, K), "calibration": 0}))
    out[f"{prefix}/train_mse"] = res["train_mse"]
    out[f"{prefix}/test_mse"] = res["test_mse"]
    out[f"{prefix}/gap"] = res["test_mse"] - res["train_mse"]
    out[f"{prefix}/shots"] = float(res["shots"])
    out[f"{prefix}/parameters"] = params


def _run_setting(setting: str, cfg: dict, seed: int, bar) -> dict:
    degree, noise, encoding = SETTINGS[setting]
    data = chebyshev_split(degree, noise, num_train=int(cfg["num_train"]),
                           num_test=int(cfg["num_test"]), seed=seed)
    L_max, K = cfg["layers"][-1], int(cfg["experts"])
    out: dict = {}
    curves: dict = {}
    rows: dict[str, list] = {"vanilla": [], "density": []}
    models = {}

    def fit(tag, num_layers, num_subs, index, record):
        rng = np.random.default_rng([seed, index, 0 if setting == "methods" else 1])
        model = SingleQubitReuploading(num_layers, num_subs, encoding=encoding, seed=rng)
        res = _train(model, data, cfg, rng, record)
        bar.update()
        return model, res

    for i, L in enumerate(cfg["layers"]):
        D = density_depth(L, K)
        for tag, (layers, subs) in (("vanilla", (L, 1)), ("density", (D, K))):
            model, res = fit(tag, layers, subs, 2 * i + (tag == "density"), L == L_max)
            _record(out, f"{setting}/{tag}/L{L}", res, model)
            rows[tag].append((L, res))
            if L == L_max:
                models[tag] = model
                h, p = res["history"], f"{setting}/{tag}/L{L}"
                curves[f"{p}/test_vs_epoch"] = curve(h["epoch"], h["test"], "epoch", "test MSE")
                curves[f"{p}/train_vs_epoch"] = curve(h["epoch"], h["train"], "epoch",
                                                      "train MSE")
                curves[f"{p}/test_vs_shots"] = curve(h["shots"], h["test"], "shots", "test MSE")
    for tag, rs in rows.items():
        Ls = [L for L, _ in rs]
        for key, label in (("test_mse", "test MSE"), ("train_mse", "train MSE")):
            curves[f"{setting}/{tag}/{key}_vs_L"] = curve(Ls, [r[key] for _, r in rs],
                                                          "L (vanilla layers)", label)
        curves[f"{setting}/{tag}/gap_vs_L"] = curve(
            Ls, [r["test_mse"] - r["train_mse"] for _, r in rs], "L (vanilla layers)",
            "test MSE - train MSE")
    # Supp. J (Fig. 17): test MSE at L_max against K (K = 1 is the vanilla model)
    by_k = {1: out[f"{setting}/vanilla/L{L_max}/test_mse"],
            K: out[f"{setting}/density/L{L_max}/test_mse"]}
    for j, k in enumerate(cfg["experts_at_max"]):
        if k in by_k:
            continue
        model, res = fit("density", density_depth(L_max, k), k, 1000 + j, False)
        _record(out, f"{setting}/density_K{k}/L{L_max}", res, model)
        by_k[k] = res["test_mse"]
    ks = sorted(by_k)
    curves[f"{setting}/test_mse_vs_K"] = curve(ks, [by_k[k] for k in ks],
                                               f"K (1 = vanilla; L = {L_max})", "test MSE")
    x_te, y_te = data[1][:, 0], data[3]
    curves[f"{setting}/truth/fit"] = curve(x_te, y_te, "x", "f(x)")
    for tag, model in models.items():
        curves[f"{setting}/{tag}/fit"] = curve(x_te, model.predict(data[1]), "x", "f(x)")
    out["curves"] = curves
    return out


def run_seed(config: dict, seed: int, progress: bool = False) -> dict:
    """One seed: every setting's L sweep (vanilla vs density K = ``experts``) and the K panel.

    Returns
    -------
    dict
        Scalars ``{setting}/{vanilla|density|density_K{k}}/L{L}/{train_mse|test_mse|gap|shots|
        parameters}`` and curves (MSE and gap against L, test MSE against K at the largest L,
        learning curves and fitted functions at the largest L).
    """
    cfg = _check(config)
    settings = list(BOTH) if cfg["setting"] == "both" else [cfg["setting"]]
    runs = len(settings) * (2 * len(cfg["layers"]) + len(
        [k for k in cfg["experts_at_max"] if k != cfg["experts"]]))
    out: dict = {"seed": seed, "curves": {}}
    with progress_bar(runs, desc=f"reuploading seed {seed}", unit="model",
                      verbose=progress) as bar:
        for setting in settings:
            res = _run_setting(setting, cfg, seed, bar)
            out["curves"].update(res.pop("curves"))
            out.update(res)
    return out


def plot(result: ExperimentResult, directory: Path) -> list[Path]:
    """Per setting: Fig. 6b's panels (test MSE, gap and train MSE against L) and Supp. J's
    (test MSE against K at the largest L, the fitted functions, test MSE against epochs)."""
    directory = Path(directory)
    setting = result.config["setting"]
    paths = []
    dens_label = f"density (K = {result.config['experts']})"
    colours = {"vanilla (L layers)": "C0", "vanilla": "C0", dens_label: "C1", "density": "C1",
               "test MSE": "C2"}  # one colour per model in every panel and figure
    for s in (list(BOTH) if setting == "both" else [setting]):
        degree = SETTINGS[s][0]
        labels = {f"{s}/vanilla/{k}": "vanilla (L layers)" for k in
                  ("test_mse_vs_L", "gap_vs_L", "train_mse_vs_L")}
        labels.update({f"{s}/density/{k}": f"density (K = {result.config['experts']})"
                       for k in ("test_mse_vs_L", "gap_vs_L", "train_mse_vs_L")})
        paths.append(plot_curves(result, [
            ("test MSE", [f"{s}/vanilla/test_mse_vs_L", f"{s}/density/test_mse_vs_L"]),
            ("generalisation gap", [f"{s}/vanilla/gap_vs_L", f"{s}/density/gap_vs_L"]),
            ("train MSE", [f"{s}/vanilla/train_mse_vs_L", f"{s}/density/train_mse_vs_L"]),
        ], directory / figure_name(result, f"reuploading-{s}-vs-L.png"),
            title=f"re-uploading, T_{degree} ({s}): vanilla vs density", labels=labels,
            colours=colours))
        L = max(result.config["layers"])
        fit_labels = {f"{s}/truth/fit": f"T_{degree}", f"{s}/vanilla/fit": "vanilla",
                      f"{s}/density/fit": "density",
                      f"{s}/vanilla/L{L}/test_vs_epoch": "vanilla",
                      f"{s}/density/L{L}/test_vs_epoch": "density",
                      f"{s}/test_mse_vs_K": "test MSE"}
        paths.append(plot_curves(result, [
            (f"test MSE against K at L = {L}", [f"{s}/test_mse_vs_K"]),
            ("fitted functions (test grid)", [f"{s}/truth/fit", f"{s}/vanilla/fit",
                                              f"{s}/density/fit"]),
            ("learning curves", [f"{s}/vanilla/L{L}/test_vs_epoch",
                                 f"{s}/density/L{L}/test_vs_epoch"]),
        ], directory / figure_name(result, f"reuploading-{s}-experts.png"),
            title=f"re-uploading, T_{degree} ({s}), L = {L}", labels=fit_labels,
            colours=colours))
    return paths


#: The claims read on Supp. J's model (T_2 and T_3), which the gate-order departure touches.
_SUPP_J = ("reuploading/supp-j", "reuploading/supp-j-experts", "reuploading/t3",
           "reuploading/t4")

PAPER = PaperProtocol(
    settings={"setting": "both", "layers": [5, 10, 20, 30, 40, 50], "experts": 5,
              "experts_at_max": [2, 7], "epochs": 300, "batch_size": 5, "learning_rate": 0.001,
              "num_train": 25, "num_test": 110, "shots_per_circuit": 1000, "curve_points": 40},
    fixed=("experts", "batch_size", "learning_rate"),
    readings={"setting": "the Methods say T_4 with noise variance 0.25 and one R_x(x) per "
                         "upload; Supp. J says T_2 with noise std 0.2 and R_y(x) R_x(x); both "
                         "run ('both'); Supp. J's T_3 and T_4 panels (Fig. 18) run as "
                         "setting='t3' and 't4'",
              "epochs": "not stated; 300",
              "layers": "the grid is not stated (L = 50 is the largest in Supp. J)",
              "experts_at_max": "Supp. J: K in {2, 7} at L = 50"},
    departures=(Departure(
        "gate order: each upload applies the data rotations and then R_z R_y R_z, where Supp. "
        "J's equation, U_l = R_y(x) R_x(x) R_z(phi) R_y(delta) R_z(omega), applies the "
        "trainable rotations first (the model starts with a trainable rotation and ends with a "
        "data rotation before Z): the T_2 and T_3 runs are another model than Supp. J's (the "
        "Methods, T_4, state no order)", touches=_SUPP_J),),
    source="Methods 'Data reuploading density QNN'; Supp. J (batch 5, Adam 1e-3, K = 5)")

EXPERIMENT = Experiment(
    name="reuploading",
    title="vanilla single-qubit re-uploading (L layers) vs density QNN (K = 5, 5 x 3D ~ 3L): "
          "overfitting noisy Chebyshev data",
    paper="Fig. 6 (Numerical results, 'Mitigating overfitting'); Methods 'Data reuploading "
          "density QNN'; Supp. J Figs. 17-18",
    quick={"setting": "methods", "layers": [5, 10], "experts": 5, "experts_at_max": [2],
           "epochs": 30, "batch_size": 5, "learning_rate": 0.001, "num_train": 25,
           "num_test": 110, "shots_per_circuit": 1000, "curve_points": 10},
    full={"setting": "both", "layers": [5, 10, 20, 30, 40, 50], "experts": 5,
          "experts_at_max": [2, 7], "epochs": 300, "batch_size": 5, "learning_rate": 0.001,
          "num_train": 25, "num_test": 110, "shots_per_circuit": 1000, "curve_points": 40},
    run_seed=run_seed,
    plot=plot,
    seeds={"quick": 2, "full": 6, "paper": 6},
    protocol=PAPER,
    reductions="The paper gives no epoch count: 300 epochs of Adam (lr 0.001, batch 5, 1500 "
               "steps) per model, what the CPU budget allows for both settings (about 34 "
               "core-minutes for 6 seeds); the L = 50 vanilla models reach train MSE below the "
               "Supp. J noise variance in our intermediate runs. L on the grid "
               "{5, 10, 20, 30, 40, 50} (the paper's grid is not stated; L = 50 is its "
               "largest). 6 seeds (data, initialisation and batch order) instead of the paper's "
               "single runs, so the claim can be told from seed noise. Simulated exactly; shots "
               "are those a parameter-shift run would need (1000 per circuit).",
)
