"""Stable short import paths for modules that live in a subpackage.

The package is laid out along the spine (``circuits/``, ``analysis/``, ``models/``,
``execution/``, ``gradients/``, ``learning/``, ``datasets/``, ``experiments/``, ``cli/``), but the
short paths of the first release keep working, with no warning: ``qdensity.ansatze`` *is*
``qdensity.circuits.ansatze`` (the same module object, so ``isinstance`` checks, pickles and
``monkeypatch`` see one module), ``qdensity.plans`` is ``qdensity.execution.plans``, and so on.

A meta-path finder resolves an alias on first import and hands back the real module; nothing is
imported before it is asked for, and nothing is copied.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
from types import ModuleType

__all__ = ["ALIASES", "resolve", "install"]

#: short path -> canonical module (a prefix: ``qdensity.ansatze.hamming`` follows ``ansatze``).
ALIASES: dict[str, str] = {
    "qdensity.gates": "qdensity.circuits.gates",
    "qdensity.loaders": "qdensity.circuits.loaders",
    "qdensity.ansatze": "qdensity.circuits.ansatze",
    "qdensity.preparation": "qdensity.circuits.preparation",
    "qdensity.tomography": "qdensity.circuits.tomography",
    "qdensity.pauli": "qdensity.analysis.pauli",
    "qdensity.mixtures": "qdensity.models.mixtures",
    "qdensity.decompositions": "qdensity.models.decompositions",
    "qdensity.plans": "qdensity.execution.plans",
    "qdensity.engines": "qdensity.execution.engines",
    "qdensity.unary": "qdensity.execution.unary",
    "qdensity.schedulers": "qdensity.execution.schedulers",
    # the engines' modules before each engine had a sub-package of its own
    "qdensity.execution.adjoint": "qdensity.execution.statevector.adjoint",
    "qdensity.execution.mitigated": "qdensity.execution.sampler.mitigated",
    "qdensity.execution.postselection": "qdensity.execution.sampler.postselection",
    "qdensity.execution.runtime_engine": "qdensity.execution.sampler.runtime",
    "qdensity.targets": "qdensity.hardware.targets",
    "qdensity.noise": "qdensity.hardware.noise",
    "qdensity.resources": "qdensity.hardware.resources",
    "qdensity.training": "qdensity.learning.training",
    "qdensity.nn": "qdensity.learning.nn",
    "qdensity.losses": "qdensity.learning.losses",
    "qdensity.optim": "qdensity.learning.optim",
    "qdensity.demo": "qdensity.experiments.demo",
    "qdensity.table1": "qdensity.experiments.table1",
    "qdensity.export": "qdensity.cli.export",
}


def resolve(name: str) -> str | None:
    """The canonical module name behind a short path, or ``None`` if ``name`` is no alias.

    >>> resolve("qdensity.ansatze.hamming")
    'qdensity.circuits.ansatze.hamming'
    >>> resolve("qdensity.circuits.gates") is None
    True
    """
    for short, real in ALIASES.items():
        if name == short or name.startswith(short + "."):
            return real + name[len(short):]
    return None


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, real: str) -> None:
        self.real = real

    def create_module(self, spec) -> ModuleType:
        module = importlib.import_module(self.real)
        self._spec = module.__spec__
        if hasattr(module, "__path__"):
            # Register the package's loaded submodules under the short path too. Otherwise the
            # first `import qdensity.ansatze.hardware_efficient` would load it afresh under that
            # name and the import system would then set the submodule as an attribute of the
            # package, hiding the function `hardware_efficient` that the package re-exports.
            prefix = self.real + "."
            for key, sub in list(sys.modules.items()):
                if key.startswith(prefix):
                    sys.modules.setdefault(spec.name + key[len(self.real):], sub)
        return module

    def exec_module(self, module: ModuleType) -> None:
        # The real module is already executed; the import system has just set its __spec__ to
        # the alias's spec: give it its own back, so the module keeps one identity.
        module.__spec__ = self._spec


    def get_code(self, fullname: str):
        """The real module's code, so ``python -m qdensity.export`` runs the real module."""
        spec = importlib.util.find_spec(self.real)
        if spec is None or not isinstance(spec.loader, importlib.abc.InspectLoader):
            raise ImportError(f"no code for {self.real!r}")
        return spec.loader.get_code(self.real)


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        real = resolve(fullname)
        if real is None:
            return None
        return importlib.util.spec_from_loader(fullname, _AliasLoader(real))


def install() -> None:
    """Put the alias finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _AliasFinder())
