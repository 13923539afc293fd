"""The documentation site builds without warnings, its internal links resolve, and its pages
render in a real browser.

The site is built once per module from ``docs/`` with warnings as errors and the notebooks not
executed (``-D nb_execution_mode=off``: the notebooks run in ``tests/test_notebooks.py``);
``QDENSITY_DOCS_HTML`` names a site already built instead (``.ci/run`` builds it with the
notebooks executed, then points the tests at it). Headless Chromium (Debian's ``chromium``)
opens the index and one API page: title, navigation, search box, and no console message (a
JavaScript error, a failed load or a log line). Without Sphinx or Chromium these tests skip
with the install line, except where ``QDENSITY_REQUIRE_DOCS=1`` (CI), where they fail.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parent.parent
REQUIRED = os.environ.get("QDENSITY_REQUIRE_DOCS") == "1"


def _unavailable(reason: str):
    if REQUIRED:
        pytest.fail(f"{reason} (QDENSITY_REQUIRE_DOCS=1)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    given = os.environ.get("QDENSITY_DOCS_HTML")
    if given:
        path = Path(given)
        assert (path / "index.html").is_file(), f"QDENSITY_DOCS_HTML={given}: no index.html"
        return path
    try:
        import myst_nb  # noqa: F401
        import sphinx  # noqa: F401
    except ImportError:
        _unavailable("the documentation needs the docs extra: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("html")
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q", "-b", "html",
         "-D", "nb_execution_mode=off", str(ROOT / "docs"), str(out)],
        capture_output=True, text=True, timeout=900, cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stdout[-3000:]}{proc.stderr[-5000:]}"
    return out


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("href", "src") and value:
                self.links.append(value)
            if name == "id" and value:
                self.ids.add(value)


def _parse(path: Path) -> _Links:
    parser = _Links()
    parser.feed(path.read_text(encoding="utf-8", errors="replace"))
    return parser


def test_every_page_of_the_site_is_there(site):
    for page in ("index.html", "getting-started.html", "design.html", "api.html", "cli.html",
                 "notebooks.html", "search.html", "genindex.html", "py-modindex.html"):
        assert (site / page).is_file(), page
    for layer in ("circuits", "models", "gradients", "execution", "hardware", "learning",
                  "experiments", "cluster"):
        assert (site / "guide" / f"{layer}.html").is_file(), layer
    notebooks = sorted(p.stem for p in (ROOT / "notebooks").glob("*.py"))
    assert len(notebooks) == 13
    for name in notebooks:
        assert (site / "notebooks" / f"{name}.html").is_file(), name
    for module in ("qdensity", "qdensity.models.density", "qdensity.execution.sampler.engine",
                   "qdensity.learning.estimators", "qdensity.cli.export"):
        assert (site / "api" / f"{module}.html").is_file(), module


def test_every_internal_link_resolves(site):
    """Every relative ``href``/``src`` of every page names a file of the site, and its
    ``#fragment`` an id on that page."""
    pages = {p: _parse(p) for p in site.rglob("*.html")}
    broken = []
    for page, parsed in pages.items():
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:")):
                continue
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            if not target.exists():
                broken.append(f"{page.relative_to(site)}: {link}")
                continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{page.relative_to(site)}: {link} (no such anchor)")
    assert not broken, f"{len(broken)} broken internal links:\n" + "\n".join(broken[:40])


def test_the_api_reference_documents_every_public_name(site):
    """Every public module of the package (no ``_`` in its path) has a page, or its package
    rebinds its name to a function (then that package's page documents it); every class and
    function in a public module's ``__all__`` is documented on the page of a module on its
    ``__module__`` path (where it is defined, or the package that re-exports it) or, if it is
    defined in a private module, on that of a module that exports it."""
    import importlib
    import pkgutil
    import types

    import qdensity

    ids: set[str] = set()
    for page in (site / "api").glob("*.html"):
        ids |= _parse(page).ids
    public = [m.name for m in pkgutil.walk_packages(qdensity.__path__, "qdensity.")
              if not any(part.startswith("_") for part in m.name.split("."))]
    assert len(public) > 50
    missing = []
    for name in public:
        module = importlib.import_module(name)
        parent, _, last = name.rpartition(".")
        rebound = not isinstance(getattr(importlib.import_module(parent), last, None),
                                 types.ModuleType)
        if not (site / "api" / f"{name}.html").is_file() and not rebound:
            missing.append(f"no page for {name}")
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr)
            if not (isinstance(obj, type) or isinstance(obj, types.FunctionType)):
                continue
            parts = obj.__module__.split(".")
            if parts[0] != "qdensity":
                continue
            homes = {f"{'.'.join(parts[:k])}.{obj.__qualname__}" for k in range(1, len(parts) + 1)}
            homes.add(f"{name}.{attr}")  # a private helper's name, documented where exported
            if not homes & ids:
                missing.append(f"{name}.{attr} ({obj.__module__}.{obj.__qualname__})")
    assert not missing, f"{len(missing)} undocumented:\n" + "\n".join(sorted(set(missing))[:40])


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    _unavailable("the browser test needs Chromium: apt-get install -y chromium")
    return ""


def _open(page: Path) -> tuple[str, list[str]]:
    """The DOM of ``page`` after its scripts ran, and the console messages it logged."""
    proc = subprocess.run(
        [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom",
         page.as_uri()],
        capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    console = [line for line in proc.stderr.splitlines() if ":CONSOLE" in line]
    return proc.stdout, console


@pytest.mark.parametrize("page", ["index.html", "api/qdensity.models.density.html"])
def test_a_page_renders_in_a_browser(site, page):
    dom, console = _open(site / page)
    title = re.search(r"<title>(.*?)</title>", dom, re.S)
    assert title and "qdensity" in title.group(1), title
    assert 'class="sphinxsidebar' in dom  # navigation
    assert re.search(r'<form[^>]*class="search', dom) and 'name="q"' in dom  # search box
    assert 'href="guide/circuits.html"' in dom or 'href="../guide/circuits.html"' in dom
    assert not console, "console messages:\n" + "\n".join(console)
    if page.startswith("api/"):
        assert 'id="qdensity.models.density.DensityQNN"' in dom  # the class is documented
