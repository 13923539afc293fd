"""A package's public names, each imported from its defining module on first use (PEP 562).

``import qdensity.gradients`` then costs nothing until a name is used, and a task imports only
the modules it touches (the command line's ``table1`` never loads the training stack).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, Sequence

__all__: list[str] = []


def lazy_exports(package: str, exports: Mapping[str, str], public: Sequence[str]
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (it must be importing: its module is in ``sys.modules``).
    exports : mapping of str to str
        Public name -> dotted path of the module that defines it.
    public : sequence of str
        The package's ``__all__``.

    Returns
    -------
    (__getattr__, __dir__)
        ``__getattr__(name)`` imports ``exports[name]``, keeps the value in the package's
        namespace (later lookups do not come back) and returns it; any other name raises
        ``AttributeError``. ``__dir__()`` lists the namespace and ``public``.
    """
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(public))

    return __getattr__, __dir__
