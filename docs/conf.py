"""Sphinx configuration of the qdensity documentation.

Build: ``sphinx-build -W --keep-going -b html docs docs/_build/html`` (the ``docs`` extra).
The notebooks (``notebooks/*.py``, jupytext percent scripts) are read through the
``docs/notebooks`` link and executed by myst-nb at build time, their outputs cached under
``docs/_build/.jupyter_cache``; ``-D nb_execution_mode=off`` renders them without running them.
"""

from __future__ import annotations

import importlib.resources
import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
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
    "sphinx_copybutton",
    "myst_nb",
    "apipages",  # docs/_ext: the API reference's pages, one per public object
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
# the notebooks are jupytext percent scripts; myst-nb reads them through jupytext
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
exclude_patterns = ["_build", "_templates", "_ext", "conf.py", "**/.ipynb_checkpoints",
                    "jupyter_execute"]
# a notebook's cells are highlighted by its kernel's language, known once it has run; with
# execution off (a quick preview build) that is not known
suppress_warnings = ["mystnb.lexer", "myst-nb.lexer"]
templates_path = ["_templates"]
# "--quick" stays two hyphens (docutils would print an en dash, which a shell refuses), and
# quotes stay straight: every command and snippet on the site can be copied as it reads
smartquotes = False

# Executing the notebooks: each runs its small settings in seconds to a minute. Their outputs
# are cached (docs/_build/.jupyter_cache, keyed by the code cells): a rebuild executes only the
# notebooks whose code changed; -D nb_execution_mode=off renders them without executing.
nb_execution_mode = "cache"
nb_execution_cache_path = str(ROOT / "docs" / "_build" / ".jupyter_cache")
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3

# MathJax 3 served with the site, not from a CDN: the math renders without a network
# connection. Its files come from the django-static-mathjax wheel (the docs extra: MathJax's own
# build, no dependencies, importable as ``mathjax``); _copy_mathjax copies the parts the
# tex-mml-chtml component loads (the TeX extensions it autoloads, the CHTML fonts, the menu and
# its accessibility parts) into the site's _static/mathjax.
try:
    MATHJAX = Path(str(importlib.resources.files("mathjax"))) / "static" / "mathjax"
except ModuleNotFoundError as err:
    raise ModuleNotFoundError("the documentation's MathJax comes from the docs extra: "
                              "pip install -e '.[docs]'") from err
MATHJAX_PARTS = ("tex-mml-chtml.js", "input", "output/chtml", "ui", "a11y", "sre", "adaptors")
mathjax_path = "mathjax/tex-mml-chtml.js"  # relative: under the site's _static

# API reference: a page per public module and one per public class or function, written from
# the modules' __all__ by docs/_ext/apipages.py; the docstrings are numpy style
autosummary_generate = False
autodoc_default_options = {"show-inheritance": True}
autodoc_member_order = "groupwise"
autoclass_content = "class"  # the class docstring holds the constructor's Parameters
autodoc_class_signature = "mixed"
# the signature carries the type hints (the docstrings' Parameters sections carry the
# meaning): a type hints "description" would add a second Parameters list to every class
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
python_maximum_signature_line_length = 88  # long signatures one parameter per line
numpydoc_show_class_members = False  # autodoc documents the members under the class
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# The theme of NumPy's, SciPy's and scikit-learn's sites
html_theme = "pydata_sphinx_theme"
html_title = f"qdensity {release}"
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_depth": 3,
    "collapse_navigation": True,
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
    "logo": {"text": f"qdensity {release}"},
}
html_context = {"default_mode": "auto"}  # light or dark, as the reader's system prefers
html_sidebars: dict[str, list[str]] = {}
html_static_path: list[str] = []
html_show_sourcelink = False

# copy buttons copy commands and code without their prompts (">>> ", "... ", "$ ") and
# without the doctest's output lines
copybutton_prompt_text = r">>> |\.\.\. |\$ "
copybutton_prompt_is_regexp = True
copybutton_only_copy_prompt_lines = True
copybutton_exclude = ".linenos, .go"



def _copy_mathjax(app, exception) -> None:
    """Copy MathJax's files into the built site's ``_static/mathjax`` (see ``mathjax_path``)."""
    if exception is not None or app.builder.format != "html":
        return
    dest = Path(app.outdir) / "_static" / "mathjax"
    for part in MATHJAX_PARTS:
        source, target = MATHJAX / "es5" / part, dest / part
        target.parent.mkdir(parents=True, exist_ok=True)
        if source.is_dir():
            shutil.copytree(source, target, dirs_exist_ok=True)
        else:
            shutil.copy2(source, target)
    shutil.copy2(MATHJAX / "LICENSE", dest / "LICENSE")


def setup(app):
    app.connect("build-finished", _copy_mathjax)
