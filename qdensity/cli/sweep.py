"""``qdensity sweep``: an optuna hyperparameter sweep of a QNNClassifier
(:func:`qdensity.learning.sweep.run_sweep`), shared by any number of workers."""

from __future__ import annotations

import json

from qdensity.circuits.ansatze.registry import estimator_ansatze
from qdensity.cli._help import texts
from qdensity.models.registry import DECOMPOSITIONS, MIXTURES

__all__ = ["add_parser"]

_SWEEP_DATASETS = ("digits", "iris", "wine", "breast_cancer")


def _cmd_sweep(args) -> int:
    from sklearn import datasets
    from sklearn.preprocessing import StandardScaler

    from qdensity.learning._study import settings_hash
    from qdensity.learning.estimators import QNNClassifier
    from qdensity.learning.sweep import PAPER_SPACE, export_trials, run_sweep, sweep_settings

    if args.dataset not in _SWEEP_DATASETS:
        raise ValueError(f"unknown dataset {args.dataset!r}; known: {', '.join(_SWEEP_DATASETS)}")
    X, y = getattr(datasets, f"load_{args.dataset}")(return_X_y=True)
    X = X / 16.0 if args.dataset == "digits" else StandardScaler().fit_transform(X)
    if args.samples is not None:
        if args.samples > len(y):
            raise ValueError(f"--samples {args.samples} is more than the {len(y)} rows of "
                             f"{args.dataset}")
        X, y = X[:args.samples], y[:args.samples]
    est = QNNClassifier(num_qubits=args.num_qubits, ansatz=args.ansatz,
                        decomposition=args.decomposition, mixture=args.mixture,
                        epochs=args.epochs, verbose=False)
    study_name = args.study
    if study_name is None:  # a study is named by what it measures
        settings = sweep_settings(X, y, est, PAPER_SPACE, 0.25, args.seed)
        study_name = f"{args.dataset}-{settings_hash(settings)}"
    study = run_sweep(X, y, est, n_trials=args.n_trials, storage=args.storage,
                      study_name=study_name, seed=args.seed, sampler_seed=args.sampler_seed,
                      verbose=not args.quiet, grace_period=args.grace_period,
                      cluster=args.cluster)
    for path in args.export:
        export_trials(study, path)
    done = [t for t in study.trials if t.state.name == "COMPLETE"]
    summary = {"study": study.study_name, "complete": len(done),
               "best_value": study.best_value if done else None,
               "best_params": study.best_params if done else None}
    print(json.dumps(summary, indent=2, default=str))
    return 0


def add_parser(sub, int_in, seed_type, max_qubits: int) -> None:
    """Add the ``sweep`` sub-command to ``qdensity``'s sub-parsers (``int_in(low, high)`` and
    ``seed_type`` are the command's argparse types).

    Examples
    --------
    >>> import argparse
    >>> sub = argparse.ArgumentParser(prog="qdensity").add_subparsers()
    >>> add_parser(sub, lambda low, high: int, int, max_qubits=12)
    >>> args = sub.choices["sweep"].parse_args(["--num-qubits", "4", "--n-trials", "8"])
    >>> args.num_qubits, args.n_trials, args.ansatz, args.storage is None
    (4, 8, 'round_robin', True)
    """
    sw = sub.add_parser("sweep", help="optuna hyperparameter sweep of a QNNClassifier (the "
                                      "paper's space); start it on many machines with one "
                                      "--storage to share a study", **texts("sweep"))
    sw.add_argument("--dataset", default="digits", help=f"one of: {', '.join(_SWEEP_DATASETS)}")
    sw.add_argument("--samples", type=int_in(2, 10**7),
                    help="use only the first SAMPLES rows (at least 2, at most the dataset's)")
    sw.add_argument("--num-qubits", type=int_in(2, max_qubits), default=8,
                    help="PCA to this many qubits")
    # choices: the estimator's own registries, read when the parser is made
    sw.add_argument("--ansatz", default="round_robin", choices=estimator_ansatze(),
                    help="QNNClassifier's ansatz")
    sw.add_argument("--decomposition", default="layers", choices=tuple(DECOMPOSITIONS),
                    help="how it is cut into sub-unitaries")
    sw.add_argument("--mixture", default="softmax", choices=tuple(MIXTURES),
                    help="distribution over the sub-unitaries")
    sw.add_argument("--epochs", type=int_in(1, 10**6), default=10,
                    help="training epochs per trial")
    sw.add_argument("--n-trials", type=int_in(1, 10**6), default=32,
                    help="COMPLETE trials the study ends with, over all workers (TPE after "
                         "a quarter of them, 1 to 10, at random)")
    sw.add_argument("--storage", default=None,
                    help="optuna storage URL (default sqlite:///qdensity-sweep.db; "
                         "postgresql+psycopg2://USER@HOST/DB (the sweep extra's psycopg2) or "
                         "mysql+pymysql://... "
                         "for many machines)")
    sw.add_argument("--study", default=None,
                    help="study name (default: DATASET-<hash of the settings>, so that other "
                         "data or another model is another study; a named study made with "
                         "other settings is an error)")
    sw.add_argument("--grace-period", type=int_in(3, 10**6), default=60, metavar="SECONDS",
                    help="a trial whose worker sent no heartbeat for this long (killed, its "
                         "machine lost) is marked FAIL and run again with the same parameters "
                         "by a live worker, up to 3 times; heartbeats every third of it "
                         "(default 60)")
    sw.add_argument("--cluster", default=None, metavar="ADDRESS",
                    help="run the trials on Dask workers: 'local', 'local:N' or "
                         "'tcp://HOST:PORT' (a running 'dask scheduler'); --storage must be "
                         "reachable from them")
    sw.add_argument("--seed", type=seed_type, default=0, help="seed of the validation split")
    sw.add_argument("--sampler-seed", type=seed_type, default=None, help="seed of optuna's sampler")
    sw.add_argument("--export", nargs="*", default=[], metavar="FILE",
                    help="write the trials to FILE.json and/or FILE.csv")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.add_argument("--json", action="store_true",
                    help="print the summary as JSON (its only output; accepted for symmetry)")
    sw.set_defaults(func=_cmd_sweep)
