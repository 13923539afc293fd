"""Sphinx configuration of the qdensity documentation.

Build: ``sphinx-build -W --keep-going -b html docs docs/_build/html`` (the ``docs`` extra).
The notebooks (``notebooks/*.py``, jupytext percent scripts) are read through the
``docs/notebooks`` link and executed by myst-nb at build time; ``-D nb_execution_mode=off``
renders them without running them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("TQDM_DISABLE", "1")  # no progress bars in the rendered outputs
os.environ.setdefault("MPLBACKEND", "Agg")

import qdensity  # noqa: E402

project = "qdensity"
author = "qdensity maintainers"
copyright = "the qdensity maintainers, Apache-2.0"
release = version = qdensity.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.mathjax",
    "sphinxarg.ext",
    "myst_nb",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
# the notebooks are jupytext percent scripts; myst-nb reads them through jupytext
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
exclude_patterns = ["_build", "_templates", "conf.py", "**/.ipynb_checkpoints",
                    "jupyter_execute"]
# a notebook's cells are highlighted by its kernel's language, known once it has run; with
# execution off (a quick preview build) that is not known
suppress_warnings = ["mystnb.lexer", "myst-nb.lexer"]
templates_path = ["_templates"]

# Executing the notebooks: each runs its small settings in seconds to a minute
nb_execution_mode = "force"
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# API reference: one page per public module, generated from the docstrings (numpy style)
autosummary_generate = True
autosummary_ignore_module_all = False
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_format = "short"
# numpydoc renders the numpy-style sections; class members are listed by autodoc itself
numpydoc_show_class_members = False
numpydoc_validation_checks: set[str] = set()

html_theme = "alabaster"
html_title = f"qdensity {release}"
html_theme_options = {
    "description": "Density quantum neural networks on Qiskit",
    "fixed_sidebar": True,
    "page_width": "1240px",  # code lines are up to 100 characters
    "sidebar_width": "240px",
    "show_relbars": True,
}
html_sidebars = {"**": ["about.html", "navigation.html", "relations.html", "searchbox.html"]}
html_static_path: list[str] = []


def _home(module: str) -> str:
    """The public module that documents what ``module`` defines: ``module`` itself, or the
    package above its first private part (``qdensity.gradients._direct`` ->
    ``qdensity.gradients``), or the package above a module whose name the package rebinds to
    a function of the same name (``qdensity.circuits.ansatze.qcnn`` is the function ``qcnn``
    there, so autosummary cannot give that module a page of its own)."""
    import importlib

    parts = module.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_"):
            return ".".join(parts[:i])
    for i in range(2, len(parts) + 1):
        parent = importlib.import_module(".".join(parts[:i - 1]))
        if not isinstance(getattr(parent, parts[i - 1], None), type(importlib)):
            return ".".join(parts[:i - 1])
    return module


_PAGES: dict[tuple[str, str], str] = {}


def _pages() -> dict[tuple[str, str], str]:
    """``(defining module, qualified name) -> the module whose page documents it``, for every
    class and function in the ``__all__`` of a public module: its :func:`_home` where that
    module exports it, else the exporting module nearest to where it is defined."""
    import importlib
    import pkgutil

    if _PAGES:
        return _PAGES
    exporters: dict[tuple[str, str], set[str]] = {}
    for info in pkgutil.walk_packages(qdensity.__path__, "qdensity."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        page = _home(info.name)
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr, None)
            defined = getattr(obj, "__module__", None)
            if callable(obj) and isinstance(defined, str) and defined.startswith("qdensity"):
                exporters.setdefault((defined, obj.__qualname__), set()).add(page)
    for key, pages in exporters.items():
        home = _home(key[0])
        if home in pages:
            _PAGES[key] = home
        else:
            def shared(page, key=key):
                return len(os.path.commonprefix([page.split("."), key[0].split(".")]))
            _PAGES[key] = sorted(pages, key=lambda page: (-shared(page), page))[0]
    return _PAGES


def _skip(app, what, name, obj, skip, options):
    """Each public name is documented once, on the page chosen by :func:`_pages`; packages
    that re-export a name link to it there. scikit-learn's ``set_<method>_request`` methods
    (metadata routing) are scikit-learn's, documented there."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    if what == "module":
        document = getattr(app.env, "current_document", None)  # Sphinx >= 8.2
        current = (getattr(document, "autodoc_module", "") if document is not None
                   else app.env.temp_data.get("autodoc:module"))
        defined = getattr(obj, "__module__", None)
        if current and callable(obj) and isinstance(defined, str):
            page = _pages().get((defined, getattr(obj, "__qualname__", name)))
            if page is not None and page != current:
                return True
    return skip


def setup(app):
    app.connect("autodoc-skip-member", _skip)
