"""The public surface as the declaration tests and the generated fuzzer see it.

Every package's ``__all__`` (``qdensity`` itself, each subpackage) and the public modules the
issue names beside them (``qdensity.cluster``, the optional torch layer): each function or class
listed there, once, under the first path that lists it.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import qdensity
from qdensity.validation import declared

#: Public modules that are not packages but hold entry points of their own.
EXTRA_MODULES = ("qdensity.cluster", "qdensity.io", "qdensity.learning.torch",
                 "qdensity.circuits.interop", "qdensity.gradients.qiskit_ml")

#: Callables that take no arguments, so there is nothing to declare: name -> why.
NO_ARGUMENTS = {
    "qdensity.hardware.targets.known_targets": "takes no arguments (lists the target names)",
    "qdensity.cluster.idle_core": "takes no arguments (reads this machine's load)",
    "qdensity.cluster.worker_name": "takes no arguments (names this process)",
    "qdensity.execution.schedulers.base.Scheduler": "a typing.Protocol: never constructed; "
    "its implementations (NeymanScheduler, ...) declare theirs",
    "qdensity.models.mixtures.Mixture": "an abstract base class: never constructed; its "
    "subclasses (FixedMixture, ...) declare theirs",
    "qdensity.learning._encoding.UnscaledFeaturesWarning": "a warning category: raised by fit "
    "through warnings.warn, never called by users",
    "qdensity.circuits.ansatze.registry.estimator_ansatze": "takes no arguments (lists the "
    "registered families the estimators accept)",
}

#: Callables kept out of the declared surface on purpose: name -> why.
NOT_DECLARED = {
    # the vocabulary itself (qdensity.validation) is not a package and is the checker
}


def public_modules() -> list[str]:
    """``qdensity``, every subpackage and :data:`EXTRA_MODULES` that import here."""
    names = ["qdensity"]
    names += sorted(m.name for m in pkgutil.walk_packages(qdensity.__path__, "qdensity.")
                    if m.ispkg and not m.name.split(".")[-1].startswith("_"))
    for extra in EXTRA_MODULES:
        try:
            importlib.import_module(extra)
        except ImportError:  # the optional torch extra
            continue
        names.append(extra)
    return names


def public_callables() -> dict[str, object]:
    """``"module.qualname" -> function or class`` for every public callable, once each."""
    out: dict[str, object] = {}
    for name in public_modules():
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            target = inspect.unwrap(obj)
            key = f"{target.__module__}.{target.__qualname__}"
            out.setdefault(key, obj)
    return dict(sorted(out.items()))


def is_estimator(obj) -> bool:
    """A scikit-learn estimator: its hyperparameters are declared as
    ``_parameter_constraints`` and checked by ``fit`` (scikit-learn's convention)."""
    return inspect.isclass(obj) and "_parameter_constraints" in dir(obj)


def declarations(obj) -> dict:
    """The declared constraints of a callable, a class's constructor or an estimator."""
    if is_estimator(obj):
        from qdensity.validation import as_constraint

        return {k: as_constraint(v) for k, v in obj._parameter_constraints.items()}
    return declared(obj)


def parameters(obj) -> dict[str, inspect.Parameter]:
    """The arguments a caller passes (``self``, ``*args`` and ``**kwargs`` left out)."""
    target = obj.__init__ if inspect.isclass(obj) else obj
    sig = inspect.signature(target)
    return {k: p for i, (k, p) in enumerate(sig.parameters.items())
            if not (inspect.isclass(obj) and i == 0)
            and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
