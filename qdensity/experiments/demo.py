"""``qdensity demo``: a round-robin OrthoQNN against its layer-by-layer density version.

On 8 qubits (paper Fig. 6, Table 1): builds both models, prints their transpiled resources on a
seeded noisy heavy-hex device, trains both on scikit-learn's digits (PCA to 8 features, unary
amplitude encoding, a classical 8 -> 10 linear read-out) with *sampled* gradient circuits on
that noisy Aer device under the same shot budget, and prints test accuracy, circuits and shots.
The pure model's gradient needs 4 x 28 = 112 parameter-shift circuits per data point; the
density model's needs n - 1 = 7 commuting-generator circuits (plus 7 forward circuits, one per
sub-unitary). A PNG plot shows test accuracy against shots spent.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from qdensity.circuits.ansatze import round_robin
from qdensity.datasets.digits import load_digits_features
from qdensity.execution.engines import SamplerEngine
from qdensity.execution.resources import compare_reports, resource_report
from qdensity.execution.targets import get_target
from qdensity.learning.nn import Linear
from qdensity.learning.training import QNNClassifier
from qdensity.models.decompositions import by_moments
from qdensity.models.density import DensityQNN, Encoding
from qdensity.models.mixtures import SoftmaxMixture
from qdensity.progress import progress_bar

__all__ = ["DemoConfig", "run_demo", "load_digits_features"]


@dataclass
class DemoConfig:
    """Settings of the demo (defaults finish in about two minutes on two cores)."""

    num_qubits: int = 8
    shots: int = 32
    budget: int = 80_000
    batch_size: int = 4
    learning_rate: float = 0.1
    test_size: int = 300
    seed: int = 7
    target: str = "heavy_hex"
    eval_every: int = 4

    @classmethod
    def quick(cls, **changes) -> DemoConfig:
        """Small settings for smoke tests (``qdensity demo --quick``, the test suite): 4 qubits,
        a 2400-shot budget per model, 60 test digits; the same code path as the full demo.

        Examples
        --------
        >>> DemoConfig.quick().num_qubits
        4
        """
        settings = {"num_qubits": 4, "shots": 16, "budget": 2400, "batch_size": 2,
                    "test_size": 60, "eval_every": 2}
        settings.update(changes)
        return cls(**settings)


def _models(cfg: DemoConfig):
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


def run_demo(config: DemoConfig | None = None, *, output_dir: str | Path = ".",
             verbose: bool = True, plot: bool = True, progress: bool | None = None) -> dict:
    """Run the demo; returns the numbers it prints.

    Parameters
    ----------
    config : DemoConfig, optional
    output_dir : path
        Where ``qdensity-demo.png`` is written.
    verbose : bool
        Print the resource table and the results.
    plot : bool
    progress : bool, optional
        Progress bars on a terminal (transpiling the resource table, then one training bar per
        model, see :mod:`qdensity.progress`); default: ``verbose``.

    Returns
    -------
    dict
        Per model: ``accuracy``, ``circuits``, ``shots``, ``steps``, ``curve`` (shots, accuracy).
    """
    cfg = config or DemoConfig()
    say = print if verbose else (lambda *a, **k: None)
    progress = verbose if progress is None else bool(progress)
    t0 = time.perf_counter()
    X_tr, X_te, y_tr, y_te = load_digits_features(cfg.num_qubits, cfg.test_size, cfg.seed)
    pure, dens = _models(cfg)
    target = get_target(cfg.target, cfg.num_qubits, seed=cfg.seed)
    say(f"qdensity demo: round-robin OrthoQNN on {cfg.num_qubits} qubits vs its layer-by-layer "
        f"density version (K = {dens.num_subunitaries})")
    say(f"target: {target.label} ({target.num_qubits} qubits, noisy, seed {cfg.seed})\n")
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
    say(compare_reports({"pure (loader + 28 RBS)": reports["pure"],
                         f"density, largest sub-unitary (k={worst})":
                             reports[f"density k={worst}"]}))
    say("")
    results = {}
    for name, model, method in (("pure", pure, "shift"), ("density", dens, "commuting")):
        # the training bar reports circuits and shots; the engine's own bars would repeat it
        engine = SamplerEngine(target=target, seed=cfg.seed, progress=False)
        curve = []

        def checkpoint(est, step, curve=curve, model=model):
            if step % cfg.eval_every == 0:
                curve.append((est.layer_.shots_spent, est.score(X_te, y_te)))

        clf = QNNClassifier(model, post=Linear(cfg.num_qubits, 10, seed=cfg.seed),
                            learning_rate=cfg.learning_rate, epochs=100,
                            batch_size=cfg.batch_size, engine=engine, shots=cfg.shots,
                            gradient=method, seed=cfg.seed, verbose=progress,
                            max_shots=cfg.budget, callback=checkpoint)
        t = time.perf_counter()
        clf.fit(X_tr, y_tr)
        acc = clf.score(X_te, y_te)
        curve.append((clf.layer_.shots_spent, acc))
        results[name] = {
            "accuracy": acc,
            "circuits": engine.ledger.total_circuits,
            "shots": engine.ledger.total_shots,
            "steps": len(clf.history_),
            "gradient_method": method,
            "seconds": time.perf_counter() - t,
            "curve": curve,
        }
        say(f"{name:<8} {method:<10} steps {len(clf.history_):>3}  circuits "
            f"{engine.ledger.total_circuits:>6}  shots {engine.ledger.total_shots:>8}  "
            f"test accuracy {acc:.3f}  ({results[name]['seconds']:.0f} s)")
    say(f"\nshot budget {cfg.budget} per model, {cfg.shots} shots per circuit, batch "
        f"{cfg.batch_size}; test accuracy is exact (noiseless) on {len(y_te)} held-out digits")
    if plot:
        path = Path(output_dir) / "qdensity-demo.png"
        _plot(results, path, cfg)
        results["plot"] = str(path.resolve())
        say(f"plot: {results['plot']}")
    say(f"total time {time.perf_counter() - t0:.0f} s")
    return results


def _plot(results: dict, path: Path, cfg: DemoConfig) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name in ("pure", "density"):
        shots, acc = zip(*results[name]["curve"], strict=True)
        ax.plot(shots, acc, marker="o", label=f"{name} ({results[name]['gradient_method']})")
    ax.set_xlabel("shots spent in training")
    ax.set_ylabel("test accuracy")
    ax.set_title(f"digits, {cfg.num_qubits} qubits, noisy {cfg.target}")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
