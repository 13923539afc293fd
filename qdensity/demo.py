"""``qdensity demo``: a round-robin OrthoQNN against its layer-by-layer density version.

The headline of the paper (Fig. 6, Table 1) in about 20 s of CPU: both models classify four
handwritten digits (scikit-learn's bundled digits 0-3, PCA to ``n = 6`` features, unary
amplitude encoding, a classical ``6 -> 4`` linear read-out). First each model is trained
*exactly* (the unary engine: no shots, no noise) to get its ceiling, the test accuracy that
model reaches when gradients cost nothing. Then both are trained with *sampled* gradient
circuits on a seeded noisy heavy-hex device under the same shot budget. The pure model's
gradient needs ``4 x 15 = 60`` parameter-shift circuits per data point (plus one forward
circuit); the density model's needs ``n - 1 = 5`` commuting-generator circuits plus 5 forward
circuits, one per sub-unitary. So at the same budget the density model takes about six times
as many steps, gets close to its ceiling, and the pure model lags. Test accuracy is always
computed exactly on held-out digits. A PNG shows test accuracy against shots spent, with the
ceilings as horizontal lines.
"""

from __future__ import annotations

import textwrap
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from qdensity.circuits.ansatze import round_robin
from qdensity.datasets.digits import load_digits_features
from qdensity.execution.sampler.engine import SamplerEngine
from qdensity.gradients.density import density_gradient_plan
from qdensity.hardware.resources import compare_reports, resource_report
from qdensity.hardware.targets import get_target
from qdensity.io import atomic_path
from qdensity.learning.nn import Linear
from qdensity.learning.training import QNNClassifier
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.mixtures import SoftmaxMixture
from qdensity.progress import progress_bar

__all__ = ["DemoConfig", "run_demo", "load_digits_features"]

_MODELS = (("pure", "shift"), ("density", "commuting"))

#: What ``qdensity demo --quick`` prints first and last.
_SMOKE = ("--quick is a smoke test: it checks that the install runs end to end. At its budget "
          "the models are not expected to learn (accuracy near chance is normal); run "
          "'qdensity demo' for the result.")


@dataclass
class DemoConfig:
    """Settings of the demo (the defaults take about 20 s of CPU time, see the README).

    Attributes
    ----------
    num_qubits : int
        Qubits, and PCA features per digit.
    num_classes : int
        Digits ``0 .. num_classes - 1`` are classified (2 to 10).
    shots : int
        Shots per circuit in sampled training.
    budget : int
        Shots per model; training stops before a step would exceed it.
    batch_size, learning_rate
        Of the sampled training (Adam).
    exact_epochs : int
        Epochs of the exact (ceiling) training, at ``exact_batch_size``.
    test_size : int
        Digits held out (of all ten classes; those of the chosen classes are kept).
    seed : int
        Data split, models, device errors and shots.
    target : str
        The noisy device (:func:`qdensity.hardware.targets.get_target`: a name, or a snapshot file).
    mitigation : {"m3"} or None
        Readout mitigation of the sampled training runs (``SamplerEngine(mitigation=...)``).
    postselect : {"hamming_weight"} or None
        Hamming-weight post-selection of the sampled training runs.
    curve_points : int
        About how many points the shots curve has (test accuracy is computed exactly there).
    smoke_test : bool
        Set by :meth:`quick`: the run only checks that the install works end to end, and the
        printed output says so (at its budget the models are not expected to learn).

    Examples
    --------
    >>> cfg = DemoConfig.quick()  # the install check behind ``qdensity demo --quick``
    >>> cfg.num_qubits, cfg.num_classes, cfg.smoke_test
    (4, 3, True)
    >>> DemoConfig(shots=32).budget  # the fields not given keep the defaults
    32000
    """

    num_qubits: int = 6
    num_classes: int = 4
    shots: int = 16
    budget: int = 32_000
    batch_size: int = 2
    learning_rate: float = 0.1
    exact_epochs: int = 4
    exact_batch_size: int = 4
    test_size: int = 400
    seed: int = 7
    target: str = "heavy_hex"
    curve_points: int = 16
    mitigation: str | None = None
    postselect: str | None = None
    smoke_test: bool = False

    @classmethod
    def quick(cls, **changes) -> DemoConfig:
        """Small settings for smoke tests (``qdensity demo --quick``, the test suite): 4 qubits,
        3 classes, a 2400-shot budget per model; the same code path as the full demo. It only
        checks the install: at this budget both models may end near chance, and the printed
        output says so (``smoke_test=True``).

        Examples
        --------
        >>> DemoConfig.quick().num_qubits
        4
        """
        settings: dict[str, Any] = {"num_qubits": 4, "num_classes": 3, "shots": 16, "budget": 2400,
                    "batch_size": 2, "exact_epochs": 1, "test_size": 100, "curve_points": 6,
                    "smoke_test": True}
        settings.update(changes)
        return cls(**settings)

    def check(self) -> None:
        """Raise ``ValueError`` naming the first bad setting."""
        # shots >= 2: a sampled gradient estimates each circuit's variance from its shots
        ints = {"num_qubits": 2, "num_classes": 2, "shots": 2, "budget": 1, "batch_size": 1,
                "exact_epochs": 1, "exact_batch_size": 1, "test_size": 20, "curve_points": 1,
                "seed": 0}
        for name, low in ints.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an int >= {low}, got {value!r}")
        if self.num_classes > 10:
            raise ValueError(f"num_classes must be at most 10 (digits), got {self.num_classes}")
        if not self.learning_rate > 0:
            raise ValueError(f"learning_rate must be > 0, got {self.learning_rate!r}")


def _models(cfg: DemoConfig) -> tuple[DensityQNN, DensityQNN]:
    n = cfg.num_qubits
    enc = Encoding.unary(n)
    pure = DensityQNN([round_robin(n)], encoding=enc, readout="unary_probabilities",
                      seed=cfg.seed)
    dec = by_moments(round_robin(n))
    dens = DensityQNN(dec.sub_unitaries, SoftmaxMixture(dec.num_subunitaries), encoding=enc,
                      readout="unary_probabilities")
    # same angles: the density model is the pure one cut into layers
    dens.set_params(theta=pure.theta)
    return pure, dens


def _data(cfg: DemoConfig):
    X_tr, X_te, y_tr, y_te = load_digits_features(cfg.num_qubits, cfg.test_size, cfg.seed)
    keep_tr, keep_te = y_tr < cfg.num_classes, y_te < cfg.num_classes
    return X_tr[keep_tr], X_te[keep_te], y_tr[keep_tr], y_te[keep_te]


def _sampler_engine(target, seed: int, cfg: DemoConfig) -> SamplerEngine:
    """The target's default sampler (the method per circuit: these 6-qubit circuits at 16
    shots are drawn from their exact noisy distributions,
    :mod:`qdensity.execution.samplers.noisy_exact`), with the configured mitigation and
    post-selection."""
    # the training bar reports circuits and shots; the engine's own bars would repeat it
    return SamplerEngine(target=target, seed=seed, progress=False, mitigation=cfg.mitigation,
                         postselect=cfg.postselect)


def _classifier(cfg: DemoConfig, model: DensityQNN, **kwargs) -> QNNClassifier:
    return QNNClassifier(model, post=Linear(cfg.num_qubits, cfg.num_classes, seed=cfg.seed),
                         learning_rate=cfg.learning_rate, seed=cfg.seed, **kwargs)


def run_demo(config: DemoConfig | None = None, *, output_dir: str | Path = ".",
             verbose: bool = True, plot: bool = True, progress: bool | None = None,
             plot_name: str = "qdensity-demo.png") -> dict:
    """Run the demo; returns the numbers it prints.

    Parameters
    ----------
    config : DemoConfig, optional
    output_dir : path
        Where the plot is written.
    verbose : bool
        Print the resource table and the results.
    plot : bool
    progress : bool, optional
        Progress bars on a terminal (transpiling the resource table, the exact trainings, then
        one training bar per model, see :mod:`qdensity.progress`); default: ``verbose``.
    plot_name : str
        File name of the plot in ``output_dir`` (``qdensity demo --quick`` writes
        ``qdensity-demo-quick.png``, so it never overwrites the full demo's).

    Returns
    -------
    dict
        Per model (``"pure"``, ``"density"``): ``accuracy`` (sampled training, exact test
        accuracy), ``ceiling`` (test accuracy of the same model trained exactly),
        ``fraction_of_ceiling``, ``circuits``, ``shots`` (never above ``budget``), ``steps``,
        ``gradient_method``, ``seconds``, ``curve`` (pairs shots, test accuracy, from 0 shots);
        ``config`` (the settings), ``plot`` (the PNG's path, when written), ``seconds``.

    Raises
    ------
    ValueError
        A bad setting in ``config`` (named in the message), or a ``budget`` that cannot pay
        for one training step of each model (checked before anything is trained).

    Examples
    --------
    A budget that cannot pay for one step is refused before anything is trained (a full run takes
    about 20 s; ``qdensity demo`` on the command line):

    >>> run_demo(DemoConfig(budget=1), verbose=False, plot=False)
    Traceback (most recent call last):
        ...
    ValueError: budget=1 shots cannot pay for one training step: ...; use a budget >= 1952
    """
    cfg = config or DemoConfig()
    cfg.check()
    say = _printer(verbose)
    progress = verbose if progress is None else bool(progress)
    t0 = time.perf_counter()
    X_tr, X_te, y_tr, y_te = _data(cfg)
    pure, dens = _models(cfg)
    models = {"pure": pure, "density": dens}
    # what one sampled training step costs each model: the budget must pay for one
    step_shots = {name: cast(int, density_gradient_plan(  # sampled: a number of shots
                      models[name], X_tr[:cfg.batch_size], method=method, shots=cfg.shots
                  ).total_shots) for name, method in _MODELS}
    name, need = max(step_shots.items(), key=lambda kv: kv[1])
    if cfg.budget < need:
        raise ValueError(f"budget={cfg.budget} shots cannot pay for one training step: a step "
                         f"of the {name} model runs {need // cfg.shots} circuits x shots="
                         f"{cfg.shots} = {need} shots; use a budget >= {need}")
    target = get_target(cfg.target, cfg.num_qubits, seed=cfg.seed)
    say(f"qdensity demo: round-robin OrthoQNN on {cfg.num_qubits} qubits vs its layer-by-layer "
        f"density version (K = {dens.num_subunitaries}), digits 0-{cfg.num_classes - 1}")
    say(f"target: {target.label} ({target.num_qubits} qubits, noisy, seed {cfg.seed})\n")
    if cfg.smoke_test:
        say(f"{_SMOKE}\n")
    circuits = {"pure": pure.circuit(0)}
    circuits.update({f"density k={k}": dens.circuit(k) for k in range(dens.num_subunitaries)})
    reports = {}
    with progress_bar(len(circuits), desc="transpile", unit="circuit", verbose=progress,
                      leave=True) as bar:
        for key, circuit in circuits.items():
            reports[key] = resource_report(circuit, target)
            bar.update()
    worst = max(range(dens.num_subunitaries),
                key=lambda k: reports[f"density k={k}"].two_qubit_count)
    gates = cfg.num_qubits * (cfg.num_qubits - 1) // 2
    say(compare_reports({f"pure (loader + {gates} RBS)": reports["pure"],
                         f"density, largest sub-unitary (k={worst})":
                             reports[f"density k={worst}"]}))
    say("")
    results: dict = {}
    # the ceilings: each model trained exactly (unary engine, no shots, no noise)
    for name, _ in _MODELS:
        clf = _classifier(cfg, models[name], epochs=cfg.exact_epochs,
                          batch_size=cfg.exact_batch_size, verbose=progress)
        clf.fit(X_tr, y_tr)
        results[name] = {"ceiling": float(clf.score(X_te, y_te))}
    epochs = f"{cfg.exact_epochs} epoch{'s' if cfg.exact_epochs != 1 else ''}"
    say(f"exact training ({epochs}, no shots): test accuracy "
        f"pure {results['pure']['ceiling']:.3f}, density {results['density']['ceiling']:.3f}"
        " (the ceilings)\n")
    every = max(1, cfg.budget // cfg.curve_points)
    for name, method in _MODELS:
        engine = _sampler_engine(target, cfg.seed, cfg)
        curve: list[tuple[int, float]] = []

        def checkpoint(est, step, curve=curve):
            shots = est.layer_.shots_spent
            if not curve or shots >= curve[-1][0] + every:
                curve.append((int(shots), float(est.score(X_te, y_te))))

        # the steps the budget allows (so the progress bar has the right length)
        clf = _classifier(cfg, models[name], epochs=1000, batch_size=cfg.batch_size,
                          engine=engine, shots=cfg.shots, gradient=method, verbose=progress,
                          max_shots=cfg.budget, max_steps=max(1, cfg.budget // step_shots[name]),
                          callback=checkpoint)
        t = time.perf_counter()
        clf.fit(X_tr, y_tr)
        acc = float(clf.score(X_te, y_te))
        if curve[-1][0] != clf.layer_.shots_spent:
            curve.append((int(clf.layer_.shots_spent), acc))
        ceiling = results[name]["ceiling"]
        results[name].update({
            "accuracy": acc,
            "fraction_of_ceiling": acc / ceiling if ceiling > 0 else float("nan"),
            "circuits": engine.ledger.total_circuits,
            "shots": engine.ledger.total_shots,
            "steps": len(clf.history_),
            "gradient_method": method,
            "seconds": time.perf_counter() - t,
            "curve": curve,
        })
        r = results[name]
        say(f"{name:<8} {method:<10} steps {r['steps']:>4}  circuits {r['circuits']:>6}  shots "
            f"{r['shots']:>7}  ({r['seconds']:.0f} s)\n{'':<8} test accuracy {acc:.3f} = "
            f"{r['fraction_of_ceiling']:.0%} of its ceiling {ceiling:.3f}")
    say(f"\nshot budget {cfg.budget} per model, {cfg.shots} shots per circuit, batch "
        f"{cfg.batch_size}; test accuracy is exact (noiseless) on {len(y_te)} held-out digits; "
        f"chance is {1 / cfg.num_classes:.2f}")
    if cfg.smoke_test:
        say(_SMOKE)
    results["config"] = asdict(cfg)
    if plot:
        path = Path(output_dir) / plot_name
        _plot(results, path, cfg, target.label)
        results["plot"] = str(path.resolve())
        say(f"plot: {results['plot']}")
    results["seconds"] = time.perf_counter() - t0
    say(f"total time {results['seconds']:.0f} s")
    return results


def _printer(verbose: bool):
    """``print`` with every line wrapped to 100 columns (a line starting with spaces keeps
    them), or a function that prints nothing."""
    if not verbose:
        return lambda *a, **k: None

    def say(text: str = "") -> None:
        lines = []
        for line in str(text).split("\n"):
            if len(line) <= 100:
                lines.append(line)
                continue
            indent = " " * (len(line) - len(line.lstrip()))
            lines.append(textwrap.fill(line, 100, subsequent_indent=indent + "  "))
        print("\n".join(lines))

    return say


def _plot(results: dict, path: Path, cfg: DemoConfig, label: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for (name, method), color in zip(_MODELS, ("tab:blue", "tab:orange"), strict=True):
        shots, acc = zip(*results[name]["curve"], strict=True)
        ax.plot(shots, acc, marker="o", ms=3, color=color, label=f"{name} ({method} gradient)")
        ax.axhline(results[name]["ceiling"], color=color, ls="--", lw=1,
                   label=f"{name}, exact training (ceiling)")
    ax.axhline(1 / cfg.num_classes, color="grey", ls=":", lw=1, label="chance")
    ax.set_xlabel("shots spent in training")
    ax.set_ylabel("test accuracy (exact)")
    ax.set_ylim(0, 1)
    ax.set_title(f"digits 0-{cfg.num_classes - 1}, {cfg.num_qubits} qubits, {cfg.shots} shots "
                 f"per circuit, noisy {label}", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
