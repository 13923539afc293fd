"""The paper's reproduction uses only qdensity's public API: every import of ``qdensity`` from
``qdensity_paper`` names a public module (no path part with a leading underscore) and, from
it, a name the module lists in ``__all__`` (or a public submodule). Read from the source with
``ast``, module-level and function-level imports alike."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import qdensity_paper

ROOT = Path(qdensity_paper.__file__).resolve().parent


def _qdensity_imports():
    for path in sorted(ROOT.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            where = f"{path.relative_to(ROOT.parent)}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "qdensity":
                        yield where, alias.name, None
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                if node.module.split(".")[0] == "qdensity":
                    for alias in node.names:
                        yield where, node.module, alias.name


def _violation(module: str, name: str | None) -> str | None:
    if any(part.startswith("_") for part in module.split(".")):
        return f"private module {module}"
    mod = importlib.import_module(module)
    if name is None:
        return None
    if name.startswith("_"):
        return f"private name {module}.{name}"
    if importlib.util.find_spec(f"{module}.{name}") is not None if hasattr(mod, "__path__") \
            else False:
        return None  # a public submodule
    public = getattr(mod, "__all__", None)
    if public is None:
        return f"{module} declares no __all__"
    if name not in public:
        return f"{module}.{name} is not in {module}.__all__"
    return None


def test_the_checker_finds_private_imports():
    assert _violation("qdensity.learning._study", "settings_hash") is not None
    assert _violation("qdensity.circuits.ansatze", "_private") is not None
    assert _violation("qdensity.circuits.ansatze", "round_robin") is None
    assert _violation("qdensity", "DensityQNN") is None


def test_the_paper_imports_only_public_qdensity_names():
    found = list(_qdensity_imports())
    assert len(found) > 50  # the reader sees the imports
    bad = sorted({f"{where}: {v}" for where, module, name in found
                  if (v := _violation(module, name)) is not None})
    assert not bad, "\n".join(bad)
