"""The examples in the package's docstrings, the README and the user guide run and print what
they say."""

import doctest
import gc
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import qdensity

MODULES = sorted(
    info.name for info in pkgutil.walk_packages(qdensity.__path__, prefix="qdensity.")
)


def test_every_module_is_collected():
    assert "qdensity.gradients.commuting" in MODULES and len(MODULES) > 20


#: Modules of optional extras and the package each needs (CI installs the extras).
OPTIONAL = {"qdensity.learning.torch": "torch", "qdensity.circuits.interop": "pennylane",
            "qdensity.gradients.qiskit_ml": "qiskit_machine_learning",
            "qdensity.execution.sampler.runtime": "qiskit_ibm_runtime",
            "qdensity.learning.sweep": "optuna", "qdensity.learning._study": "optuna"}


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    if name in OPTIONAL:
        pytest.importorskip(OPTIONAL[name])
    module = importlib.import_module(name)
    # doctest's debugger reset walks linecache.checkcache(): a garbage collection inside that
    # walk can run SQLAlchemy's finalizers (optuna's storages, earlier tests), which delete
    # their generated-code entries mid-walk (KeyError in linecache). Keep the collector off
    # while the examples run (a full collection before each module cost about a second).
    gc.disable()
    try:
        result = doctest.testmod(module,
                                 optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    finally:
        gc.enable()
    assert result.failed == 0, f"{result.failed} doctest example(s) failed in {name}"


def test_readme_example_runs_and_its_comments_hold():
    """The README's first Python example runs as written; the counts its comments state hold."""
    readme = Path(__file__).resolve().parents[1] / "README.md"
    code = re.findall(r"```python\n(.*?)```", readme.read_text(), re.S)[0]
    scope: dict = {}
    exec(compile(code, str(readme), "exec"), scope)  # noqa: S102 - our own README
    assert scope["model"].predict(scope["X"]).shape == (16, 8)
    assert scope["plan"].meta["gradient_circuits"] == 7
    assert scope["grads"].jacobians[0].shape == (2, 8, 4)  # the 2 sampled points
    # per point: 7 forward circuits (one per sub-unitary) + 7 commuting gradient circuits
    assert scope["engine"].ledger.total_circuits == 2 * 14
    assert scope["engine"].ledger.total_shots == 2 * 14 * 200
    assert scope["grad"].num_gradient_circuits == 25


def test_readme_classification_example_runs_and_scores_what_it_says():
    """The user guide's observable-model classifiers (a read-out head; one output per class)
    fit (docs/guide/models.md, which moved there from the README)."""
    page = Path(__file__).resolve().parents[1] / "docs" / "guide" / "models.md"
    code = [c for c in re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
            if "QNNClassifier" in c][0]
    scope: dict = {}
    exec(compile(code, str(page), "exec"), scope)  # noqa: S102 - our own documentation
    X, y = scope["X"], scope["y"]
    assert scope["scalar"].predict(X[:2]).shape == (2,)          # one output per input
    assert scope["multi"].predict(X[:2]).shape == (2, 4)         # one per class
    assert scope["head"].score(X, y % 2) >= 0.9
    assert scope["direct"].score(X, y) >= 0.95
