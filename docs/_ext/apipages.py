"""The API reference, generated from the ``__all__`` of qdensity's public modules.

The public API is what a public module (no ``_`` in its dotted path) lists in ``__all__``.
This extension writes, before Sphinx reads the sources:

- one page per public module, ``api/<module>.rst``: its docstring, then tables of the classes,
  functions, constants and sub-modules in its ``__all__`` (a name that the module re-exports
  links to the page where it is documented);
- one page per public class or function, ``api/<home>.<name>.rst``, where ``<home>`` is the
  module of its page: among the modules that export it, the one nearest to where it is
  defined (``qdensity.models.density.DensityQNN``, not ``qdensity.DensityQNN``). Each object
  is documented once, on that page, whatever number of modules export it; its page lists the
  import paths that reach it.

Constants are documented on the page of the module nearest to their definition. A page is only
rewritten when its text changes, so an unchanged API does not make Sphinx read it again.

A cross-reference to a re-exported name (``:class:`qdensity.DensityQNN```), or to the bare name
of one public object (``:class:`DensityQNN``` from another module's docstring), resolves to the
object's page (``missing-reference``), so pages may cite any public import path.
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil
import re
import types
from dataclasses import dataclass, field
from pathlib import Path

from qdensity.io import atomic_write_text

PACKAGE = "qdensity"


@dataclass
class Entry:
    """A public object: where it is documented and every public path that exports it."""

    obj: object
    kind: str  # "class", "function", "data" or "module"
    home: str  # the module whose page documents it (for classes/functions: the module part
    name: str  # of its page's name); the name it has there
    exports: list[str] = field(default_factory=list)  # "module.name" for every exporter

    @property
    def target(self) -> str:
        return f"{self.home}.{self.name}" if self.kind != "module" else self.name


def public_modules() -> list[str]:
    """The package and every module of it with no private part in its dotted path."""
    package = importlib.import_module(PACKAGE)
    names = [PACKAGE] + [info.name for info in pkgutil.walk_packages(package.__path__,
                                                                        f"{PACKAGE}.")]
    return [n for n in names if not any(p.startswith("_") for p in n.split("."))]


def _kind(obj: object) -> str:
    if isinstance(obj, types.ModuleType):
        return "module"
    if inspect.isclass(obj):
        return "class"
    if inspect.isfunction(obj) or (callable(obj) and hasattr(obj, "__wrapped__")):
        return "function"
    return "data"


def _shared(a: str, b: str) -> int:
    return len(os.path.commonprefix([a.split("."), b.split(".")]))


def collect() -> tuple[dict[str, list[tuple[str, Entry]]], list[Entry]]:
    """``module -> [(name in __all__, entry)]`` for every public module, and the entries."""
    listing: dict[str, list[tuple[str, Entry]]] = {}
    entries: dict[object, Entry] = {}
    for module_name in public_modules():
        module = importlib.import_module(module_name)
        rows = listing.setdefault(module_name, [])
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr)
            kind = _kind(obj)
            if kind == "module":
                key: object = ("module", obj.__name__)
            elif kind == "data":  # small ints are shared objects: the name is the identity
                key = ("data", attr, id(obj))
            else:
                key = id(obj)
            entry = entries.get(key)
            if entry is None:
                entry = entries[key] = Entry(obj, kind, module_name, attr)
                if kind == "module":
                    entry.name = obj.__name__
            entry.exports.append(f"{module_name}.{attr}")
            rows.append((attr, entry))
    for entry in entries.values():
        if entry.kind in ("class", "function"):
            defined = getattr(entry.obj, "__module__", "") or ""
            best = sorted(entry.exports, key=lambda path: (
                -_shared(path.rpartition(".")[0], defined), -path.count("."), path))[0]
        elif entry.kind == "data":  # the deepest exporter: nearest to its definition
            best = sorted(entry.exports, key=lambda path: (-path.count("."), path))[0]
        else:
            continue
        entry.home, _, entry.name = best.rpartition(".")
    return listing, list(entries.values())


_ABBREVIATIONS = ("eq", "Eq", "eqs", "Fig", "Figs", "e.g", "i.e", "Supp", "Prop", "Cor",
                  "Sec", "al", "vs", "cf", "approx", "Thm", "Ref", "Alg", "No")


def summary(obj: object) -> str:
    """The first sentence of ``obj``'s docstring, on one line ('' without a docstring): the
    text up to the first full stop that ends a sentence (not one inside an inline literal or
    after an abbreviation such as "eq." or "e.g.")."""
    doc = inspect.getdoc(obj) if not isinstance(obj, (int, float, str, tuple, dict, frozenset)) \
        else None
    if not doc:
        return ""
    paragraph = " ".join(line.strip() for line in doc.strip().split("\n\n")[0].splitlines())
    for match in re.finditer(r"\.(\s|$)", paragraph):
        head = paragraph[:match.start()]
        if head.count("``") % 2 or head.replace("``", "").count("`") % 2:
            continue
        if head.rsplit(" ", 1)[-1].lstrip("(").endswith(_ABBREVIATIONS):
            continue
        return head + "."
    return paragraph


_TITLES = {"module": "Modules", "class": "Classes", "function": "Functions", "data": "Constants"}


def _underline(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def _relative(name: str, module_name: str) -> str:
    """``name`` as autosummary wants it on ``module_name``'s page (relative below it)."""
    return name[len(module_name) + 1:] if name.startswith(f"{module_name}.") else name


def module_page(module_name: str, rows: list[tuple[str, Entry]], modules: list[str]) -> str:
    """The reStructuredText of a module's page."""
    lines = [_underline(module_name), f".. automodule:: {module_name}\n   :no-members:\n",
             f".. currentmodule:: {module_name}\n"]
    listed = {entry.name for _, entry in rows if entry.kind == "module"}
    children = [m for m in modules if m.rpartition(".")[0] == module_name and m not in listed]
    own = [entry for _, entry in rows if entry.kind in ("class", "function")
           and entry.home == module_name]
    for kind in ("class", "function", "data", "module"):
        group = [(attr, entry) for attr, entry in rows if entry.kind == kind]
        if not group:
            continue
        lines.append(f".. rubric:: {_TITLES[kind]}\n")
        if kind == "data":
            for attr, entry in group:
                if entry.home == module_name:
                    lines.append(f".. autodata:: {attr}\n   :no-value:\n" if isinstance(
                        entry.obj, dict) else f".. autodata:: {attr}\n")
                else:
                    lines.append(f"``{attr}``: the same object as :data:`{entry.target}`.\n")
            continue
        if kind == "module":
            lines.append(".. autosummary::\n")
            lines.extend(f"   {_relative(entry.name, module_name)}" for _, entry in group)
            lines.append("")
            continue
        lines.append(".. list-table::\n   :class: autosummary longtable\n   :widths: 35 65\n")
        role = "class" if kind == "class" else "func"
        for attr, entry in group:
            lines.append(f"   * - :py:{role}:`{attr} <{entry.target}>`")
            lines.append(f"     - {summary(entry.obj)}")
        lines.append("")
    if children:
        lines.append(".. rubric:: Sub-modules\n")
        lines.append(".. autosummary::\n")
        lines.extend(f"   {_relative(child, module_name)}" for child in children)
        lines.append("")
    pages = [entry.target for entry in own] + [
        m for m in modules if m.rpartition(".")[0] == module_name]
    if pages:
        lines.append(".. toctree::\n   :hidden:\n")
        lines.extend(f"   {page}" for page in pages)
        lines.append("")
    return "\n".join(lines) + "\n"


def object_page(entry: Entry) -> str:
    """The reStructuredText of a class's or a function's page."""
    others = [path for path in entry.exports if path != entry.target]
    lines = [_underline(entry.name), f".. currentmodule:: {entry.home}\n"]
    if others:
        paths = ", ".join(f"``{path}``" for path in sorted(others, key=len))
        lines.append(f"Also exported as {paths}.\n")
    if entry.kind == "class":
        lines.append(f".. autoclass:: {entry.name}\n   :members:\n   :show-inheritance:\n")
    else:
        lines.append(f".. autofunction:: {entry.name}\n")
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> None:
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        atomic_write_text(path, text)  # a full disk leaves the old page whole


_TARGETS: dict[str, str] = {}
_SHORT: dict[str, set[str]] = {}  # a public object's own name -> its documented targets


def generate(outdir: Path) -> dict[str, str]:
    """Write the API pages into ``outdir``; return ``public path -> documented target``."""
    listing, entries = collect()
    outdir.mkdir(parents=True, exist_ok=True)
    modules = list(listing)
    wanted = set()
    for module_name, rows in listing.items():
        wanted.add(f"{module_name}.rst")
        _write(outdir / f"{module_name}.rst", module_page(module_name, rows, modules))
    for entry in entries:
        if entry.kind in ("class", "function"):
            wanted.add(f"{entry.target}.rst")
            _write(outdir / f"{entry.target}.rst", object_page(entry))
        for path in entry.exports:
            _TARGETS[path] = entry.target
        if entry.kind in ("class", "function"):
            _SHORT.setdefault(entry.name, set()).add(entry.target)
    for stale in outdir.glob("*.rst"):
        if stale.name not in wanted:
            stale.unlink()
    return _TARGETS


def _on_builder_inited(app) -> None:
    generate(Path(app.srcdir) / "api")


def _on_missing_reference(app, env, node, contnode):
    """Resolve a reference to a public path that re-exports an object to its page."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "")
    module = node.get("py:module")
    candidates = [target] + ([f"{module}.{target}"] if module else [])
    for name in candidates:
        documented = _TARGETS.get(name.lstrip("~."))
        short = _SHORT.get(name.lstrip("~."), set())
        if documented is None and len(short) == 1:  # a bare name that one public object has
            documented = next(iter(short))
        if documented and documented != name:
            found = env.get_domain("py").resolve_any_xref(env, node["refdoc"], app.builder,
                                                          documented, node, contnode)
            if found:
                return found[0][1]
    return None


def _bases(app, name, obj, options, bases) -> None:
    """No "Bases: object" line: only real base classes are worth a line."""
    if list(bases) == [object]:
        bases.clear()


def _skip(app, what, name, obj, skip, options):
    """scikit-learn's ``set_<method>_request`` methods (metadata routing) are documented by
    scikit-learn, not on qdensity's estimator pages."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    return None


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    app.connect("autodoc-skip-member", _skip)
    app.connect("autodoc-process-bases", _bases)
    app.connect("missing-reference", _on_missing_reference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
