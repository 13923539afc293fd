"""The package layout: one-way imports along the spine, no cycles, one import path per module,
and modules of one job under ~500 lines.

The import graph is read from the source with ``ast`` (module-level and function-level imports
alike), independently of what Python happens to have imported.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import qdensity

ROOT = Path(qdensity.__file__).resolve().parent

#: Subpackages from the bottom of the spine to the top: a module may import only from its own
#: layer or a layer below it (docs/design.md, "The spine"; CONTRIBUTING.md).
LAYERS = [
    "_lazy",
    "_constraints",
    "validation",
    "io",
    "progress",
    "cluster",
    "datasets",
    "analysis",
    "circuits",
    "hardware",
    "execution",
    "models",
    "gradients",
    "learning",
    "demo",
    "cli",
]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _imports(name: str, path: Path) -> set[str]:
    """qdensity modules that ``name`` imports, at any depth of its source."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            # "from pkg import sub" imports the submodule pkg.sub when there is one
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODULES else mod
                       for a in node.names]
        else:
            continue
        for target in targets:
            if target.startswith("qdensity"):
                out.add(target)
    out.discard(name)
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_every_import_names_a_real_module():
    missing = {(m, t) for m, targets in GRAPH.items() for t in targets if t not in MODULES}
    assert not missing


def test_no_import_cycle_between_modules():
    assert _find_cycle(GRAPH) is None


def test_no_import_cycle_between_packages():
    packages: dict[str, set[str]] = {}
    for module, targets in GRAPH.items():
        if module == "qdensity":
            continue
        packages.setdefault(_layer(module), set()).update(
            _layer(t) for t in targets if t != "qdensity" and _layer(t) != _layer(module))
    assert _find_cycle(packages) is None


def test_imports_run_one_way_along_the_spine():
    assert {_layer(m) for m in MODULES if m != "qdensity"} == set(LAYERS)
    upward = sorted(
        f"{module} -> {target}"
        for module, targets in GRAPH.items() if module != "qdensity"
        for target in targets
        if LAYERS.index(_layer(target)) > LAYERS.index(_layer(module))
    )
    assert not upward


def test_modules_stay_under_500_lines():
    long = {m: n for m, p in MODULES.items() if (n := len(p.read_text().splitlines())) > 500}
    assert not long


def test_unknown_attribute_of_the_package_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_module"):
        qdensity.no_such_module  # noqa: B018


def test_importing_a_submodule_keeps_the_package_functions():
    """In a fresh interpreter (the first import is the one that matters): the submodule
    ``hardware_efficient`` must not replace the function of that name that
    ``qdensity.circuits.ansatze`` re-exports."""
    code = (
        "import qdensity.circuits.ansatze.hardware_efficient\n"
        "from qdensity.circuits.ansatze import hardware_efficient\n"
        "assert hardware_efficient(2, 1).num_qubits == 2\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


def test_package_names_load_lazily_and_are_the_defining_modules_objects():
    """``import qdensity`` imports no subpackage, scikit-learn or Aer (fresh interpreter); each
    public name, on first use, is the object its defining module exports."""
    code = (
        "import sys, qdensity\n"
        "heavy = [m for m in ('sklearn', 'qiskit_aer', 'qdensity.learning', 'qdensity.models')\n"
        "         if m in sys.modules]\n"
        "assert not heavy, heavy\n"
        "from qdensity import DensityQNN\n"
        "assert 'qdensity.models.density' in sys.modules and 'sklearn' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    assert set(qdensity.__all__) - {"__version__"} == set(qdensity._EXPORTS)
    for name, module in qdensity._EXPORTS.items():
        assert getattr(qdensity, name) is getattr(importlib.import_module(module), name)
        assert name in dir(qdensity)
    assert qdensity.circuits is importlib.import_module("qdensity.circuits")


def test_contributing_spine_lists_the_layers():
    """CONTRIBUTING.md's spine names the layers of ``LAYERS``, top (cli) to bottom."""
    text = (ROOT.parent / "CONTRIBUTING.md").read_text()
    block = text.split("## The spine", 1)[1].split("\n\n", 2)[1]
    rows = [line.split()[0] for line in block.splitlines()  # not the continuation lines
            if line.startswith("    ") and not line.startswith("     ")]
    assert rows == LAYERS[::-1]
