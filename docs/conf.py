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
    "show_relbars": True,
}
html_sidebars = {"**": ["about.html", "navigation.html", "relations.html", "searchbox.html"]}
html_static_path: list[str] = []


def _home(module: str) -> str:
    """The public module that documents what ``module`` defines: ``module`` itself, or the
    package above its first private part (``qdensity.gradients._direct`` ->
    ``qdensity.gradients``)."""
    parts = module.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_"):
            return ".".join(parts[:i])
    return module


def _skip(app, what, name, obj, skip, options):
    """Each public name is documented once, on the page of the module that defines it (or of
    the package that re-exports it from a private ``_name.py``); packages that re-export a
    name link to it there. scikit-learn's ``set_<method>_request`` methods (metadata routing)
    are scikit-learn's, documented there."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    if what == "module":
        document = getattr(app.env, "current_document", None)  # Sphinx >= 8.2
        current = (getattr(document, "autodoc_module", "") if document is not None
                   else app.env.temp_data.get("autodoc:module"))
        defined = getattr(obj, "__module__", None)
        if (current and isinstance(defined, str) and defined.startswith("qdensity")
                and callable(obj) and _home(defined) != current):
            return True
    return skip


def setup(app):
    app.connect("autodoc-skip-member", _skip)
