"""The documentation site builds without warnings, its internal links resolve, its API reference
gives each public object one page, nothing internal shows on it, and its pages render in a real
browser.

The site is built once per module from ``docs/`` with warnings as errors and the notebooks not
executed (``-D nb_execution_mode=off``: the notebooks run in ``tests/test_notebooks.py``);
``QDENSITY_DOCS_HTML`` names a site already built instead (``.ci/run`` builds it with the
notebooks executed, then points the tests at it). Headless Chromium (Debian's ``chromium``)
opens the index, a guide page and an API page (title, navigation, search, math, and no console
message: a JavaScript error, a failed load or a log line), checks what a copy button copies,
and opens the command-line page, whose example command lines are read back from the rendered
text and parsed by the real parser (an en dash for ``--`` would fail). Without Sphinx or
Chromium these tests skip with the install
line, except where ``QDENSITY_REQUIRE_DOCS=1`` (CI), where they fail.
"""

from __future__ import annotations

import inspect
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
    for name in ("qdensity.models.density.DensityQNN", "qdensity.circuits.gates.RBSGate",
                 "qdensity.learning.estimators.QNNClassifier",
                 "qdensity.circuits.ansatze.hamming.pyramid"):
        assert (site / "api" / f"{name}.html").is_file(), name


def test_every_internal_link_resolves(site):
    """Every relative ``href``/``src`` of every page names a file of the site, and its
    ``#fragment`` an id on that page."""
    pages = {p: _parse(p) for p in site.rglob("*.html")
             if "_static" not in p.relative_to(site).parts}  # the theme's template macros
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


def _public_objects() -> dict[int, tuple[object, list[str]]]:
    """``id -> (object, its public paths)`` for every class and function in the ``__all__`` of a
    public module (no ``_`` in its dotted path), read off the package itself."""
    import importlib
    import pkgutil

    import qdensity

    names = ["qdensity"] + [m.name for m in pkgutil.walk_packages(qdensity.__path__, "qdensity.")
                            if not any(part.startswith("_") for part in m.name.split("."))]
    found: dict[int, tuple[object, list[str]]] = {}
    for name in names:
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr)
            if inspect.isclass(obj) or inspect.isfunction(obj):
                found.setdefault(id(obj), (obj, []))[1].append(f"{name}.{attr}")
    return found


def _documented(page: Path) -> list[str]:
    """The ids of the classes and functions a page documents (Sphinx's ``py class`` and
    ``py function`` descriptions)."""
    text = page.read_text(encoding="utf-8")
    return re.findall(r'<dl class="py (?:class|function)">\s*<dt class="sig sig-object py" '
                      r'id="([^"]+)"', text)


def test_the_api_reference_gives_every_public_object_one_page(site):
    """Every public module has a page; every class and function in a public module's
    ``__all__`` is documented exactly once on the whole site, on a page of its own named by
    one of its public paths (``api/<path>.html``), whatever number of modules export it."""
    import importlib
    import pkgutil

    import qdensity

    modules = [m.name for m in pkgutil.walk_packages(qdensity.__path__, "qdensity.")
               if not any(part.startswith("_") for part in m.name.split("."))]
    assert len(modules) > 50
    missing = [m for m in ["qdensity", *modules] if not (site / "api" / f"{m}.html").is_file()]
    assert not missing, f"no page for the modules {missing}"
    documented: dict[str, list[str]] = {}
    for page in site.rglob("*.html"):
        for target in _documented(page):
            documented.setdefault(target, []).append(str(page.relative_to(site)))
    objects = _public_objects()
    assert len(objects) > 200
    problems = []
    for _obj, paths in objects.values():
        ids = [path for path in paths if path in documented]
        pages = [page for path in ids for page in documented[path]]
        if len(pages) != 1:
            problems.append(f"{paths[0]} documented {len(pages)} times: {pages}")
        elif pages[0] != f"api/{ids[0]}.html":
            problems.append(f"{ids[0]} documented on {pages[0]}, not on its own page")
        else:
            importlib.import_module(ids[0].rpartition(".")[0])  # a real import path
    assert not problems, f"{len(problems)} problems:\n" + "\n".join(sorted(problems)[:40])


def _field_lists(html: str) -> list[str]:
    """The field names (``Parameters``, ``Returns``, ...) of the field lists in ``html``."""
    return re.findall(r'<dt class="field-(?:odd|even)">([^<]+)', html)


def test_a_class_page_has_one_parameters_section(site):
    """The constructor's arguments are listed once per class (the class docstring's
    ``Parameters``, not a second list made from the type hints), on every class page."""
    pages = [site / "api" / f"{paths[0]}.html" for obj, paths in _public_objects().values()
             if inspect.isclass(obj)]
    twice = []
    for page in pages:
        if not page.is_file():  # named by another of its paths: the test above says which
            continue
        html = page.read_text(encoding="utf-8")
        start = html.index('<dl class="py class">')
        members = re.search(r'<dl class="py (?:method|property|attribute|function)">',
                            html[start:])
        own = html[start:start + members.start()] if members else html[start:]
        if _field_lists(own).count("Parameters") > 1:
            twice.append(page.name)
    assert len(pages) > 50
    assert not twice, f"classes with two Parameters sections: {twice}"


#: Internal notes that must not reach a page: work-tracking references and talk about the way
#: the project is organised rather than about the package.
INTERNAL = re.compile(r"\b(?:issue|item|wave|session) ?#?\d+\b", re.IGNORECASE)


class _Text(HTMLParser):
    """The visible text of a page (no scripts or styles), and the text of its code cells."""

    def __init__(self):
        super().__init__()
        self.parts: list[str] = []
        self.code: list[str] = []
        self._skip = 0
        self._in_code = 0

    def handle_starttag(self, tag, attrs):
        if tag in ("script", "style"):
            self._skip += 1
        classes = dict(attrs).get("class") or ""
        if tag == "div" and ("cell_input" in classes or self._in_code):
            self._in_code += 1

    def handle_endtag(self, tag):
        if tag in ("script", "style"):
            self._skip -= 1
        if tag == "div" and self._in_code:
            self._in_code -= 1

    def handle_data(self, data):
        if not self._skip:
            self.parts.append(data)
            if self._in_code:
                self.code.append(data)


def _text(html: str) -> _Text:
    parser = _Text()
    parser.feed(html)
    return parser


def test_no_page_carries_internal_notes(site):
    """No page says "issue 14", "item 5" and the like, and no notebook's code calls a private
    method or reads a private attribute (``obj._name``): the examples use the public API."""
    notes, private = [], []
    for page in sorted(site.rglob("*.html")):
        if page.name in ("genindex.html", "search.html"):
            continue
        parsed = _text(page.read_text(encoding="utf-8"))
        text = "".join(parsed.parts)
        notes += [f"{page.relative_to(site)}: {m.group(0)!r}" for m in INTERNAL.finditer(text)]
        code = "".join(parsed.code)
        private += [f"{page.relative_to(site)}: {m.group(0)!r}"
                    for m in re.finditer(r"[\w\])]\._[a-z]\w*", code)]
    assert not notes, "internal notes on the site:\n" + "\n".join(notes[:40])
    assert not private, "private names in notebook code:\n" + "\n".join(private[:40])
    assert (site / "notebooks" / "quickstart.html").is_file()


def test_the_internal_note_patterns_catch_what_they_should():
    """The patterns of the test above, on text that must be caught and text that must not."""
    assert INTERNAL.search("beyond the paper; issue 14 item 5")
    assert INTERNAL.search("see Issue #43")
    assert not INTERNAL.search("the paper's Table 1, eq. 14, 5 items")
    parsed = _text('<div class="cell_input"><pre>bound = model._sub_theta(k)</pre></div>'
                   '<p>obj._name in prose</p>')
    assert re.findall(r"[\w\])]\._[a-z]\w*", "".join(parsed.code)) == ["l._sub_theta"]


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


#: Console lines a page may log: the theme's informational notes ("[PST]: Changed to auto
#: mode ...", console.log from its own script).
THEME_LOG = re.compile(r':INFO:CONSOLE:\d+\] "\[PST\]: [^"]*", source: \S+/_static/scripts/'
                       r'pydata-sphinx-theme\.js')


def _local_mathjax(page: Path, dom: str) -> Path:
    """The MathJax script ``page`` loads: served with the site (docs/conf.py copies it from the
    docs extra's django-static-mathjax), so the math renders without a network connection."""
    src = re.search(r'<script[^>]*src="([^"]*mathjax[^"]*)"', dom)
    assert src, "the page does not load MathJax"
    assert "http" not in src.group(1) and not src.group(1).startswith("//"), src.group(1)
    return page.parent.joinpath(unquote(src.group(1))).resolve()


@pytest.mark.parametrize("page", ["index.html", "guide/models.html",
                                  "api/qdensity.models.density.DensityQNN.html"])
def test_a_page_renders_in_a_browser(site, page):
    """Title, navigation, search, copy buttons on code, math, and no other console message."""
    dom, console = _open(site / page)
    title = re.search(r"<title>(.*?)</title>", dom, re.S)
    assert title and "qdensity" in title.group(1), title
    assert 'class="bd-sidebar-primary' in dom  # navigation: the sidebar and the top bar
    assert re.search(r'class="[^"]*\bnavbar-nav\b', dom)
    assert re.search(r'<form[^>]*class="bd-search', dom) and 'name="q"' in dom  # search box
    linked = {(site / page).parent.joinpath(href).resolve()
              for href in re.findall(r'href="([^"#:]+)', dom)}
    for section in ("getting-started", "guide/index", "notebooks", "api", "cli"):  # top bar
        assert (site / f"{section}.html").resolve() in linked, section
    if page != "index.html":  # sphinx-copybutton put its buttons on the code blocks
        assert 'class="copybtn' in dom
    others = [line for line in console if not THEME_LOG.search(line)]
    assert not others, "console messages:\n" + "\n".join(others)
    # the math, typeset by the site's own MathJax (no network needed): MathJax's output element
    # inside Sphinx's math markup, and no TeX source left over
    assert _local_mathjax(site / page, dom).is_file(), "the site lacks its MathJax"
    assert 'class="math' in dom, "no math on the page"
    assert "<mjx-container" in dom, "MathJax did not typeset the math"
    assert not re.search(r'class="math[^"]*">\\\(', dom), "math left as TeX source"
    if page.startswith("api/"):
        assert 'id="qdensity.models.density.DensityQNN"' in dom  # the class is documented


def test_a_copy_button_copies_the_code_without_prompts_or_output(site, tmp_path):
    """The copy button of a docstring example copies what a user would type: the lines of the
    docstring's ``>>>``/``...`` prompts without the prompts, and none of the output lines
    (the oracle: the docstring itself). Run in Chromium with the site's own copybutton.js and
    its configuration (its text-filtering functions and arguments, read from the built
    script), on a copy of the page that reports what the button would copy."""
    import html as htmllib
    import json

    from qdensity.models.density import DensityQNN

    page = site / "api" / "qdensity.models.density.DensityQNN.html"
    script = (site / "_static" / "copybutton.js").read_text(encoding="utf-8")
    arguments = re.search(r"return formatCopyText\(text, (.*?)\)\n", script).group(1)
    exclude = re.search(r"let exclude = '([^']*)'", script).group(1)
    # the button's own functions (declared inside copybutton.js's set-up function)
    functions = script[script.index("function escapeRegExp"):script.index("var copyTargetText")]
    probe = ('<script>' + functions + '{'
             ' const pre = document.querySelector("div.highlight pre");'
             ' const out = document.createElement("pre"); out.id = "copied";'
             f" out.textContent = JSON.stringify(formatCopyText(filterText(pre, '{exclude}'),"
             f" {arguments})); document.body.appendChild(out); }}</script>")
    text = page.read_text(encoding="utf-8")
    copy = tmp_path / page.name
    copy.write_text(text.replace("<head>", f'<head><base href="{page.parent.as_uri()}/">', 1)
                    .replace("</body>", probe + "</body>", 1), encoding="utf-8")
    dom, _ = _open(copy)
    copied = json.loads(htmllib.unescape(re.search(r'<pre id="copied"[^>]*>(.*?)</pre>', dom,
                                                   re.S).group(1)))
    lines = inspect.getdoc(DensityQNN).split("Examples\n--------\n")[1].splitlines()
    typed = [line[4:] for line in lines if line.startswith((">>> ", "... "))]
    assert copied.rstrip("\n") == "\n".join(typed), copied
    assert not any(line.startswith(">>>") for line in copied.splitlines())


def _help_options(command: tuple[str, ...] = ()) -> set[str]:
    """Every ``--option`` in the help of ``qdensity COMMAND...`` and of its sub-commands, at
    every depth (``qdensity results report --docs``)."""
    import contextlib
    import io

    from qdensity.cli.main import _parser

    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        _parser().parse_args([*command, "--help"])
    text = out.getvalue()
    found = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))
    sub = re.search(r"^ {2}\{([a-z0-9_,-]+)\}", text, re.M)  # the sub-commands' choices
    for name in sub.group(1).split(",") if sub and len(command) < 3 else []:
        found |= _help_options((*command, name))
    return found


def test_the_command_line_page_reads_as_typed(site):
    """The command-line page, rendered in Chromium: its example command lines, read back from
    the page's text, parse with qdensity's own parser (``qdensity demo --quick`` among them),
    every ``--option`` it shows is one of the parser's, and no option's dashes were turned into
    an en or em dash (a shell refuses ``qdensity demo –quick``)."""
    import shlex

    from qdensity.cli.main import _parser

    dom, _ = _open(site / "cli.html")
    text = "".join(_text(dom[dom.index("<article"):dom.index("</article>")]).parts)
    assert not re.search(r"[\u2013\u2014][a-z]", text), "a dash became an en or em dash"
    lines = [line.strip().removeprefix("examples:").strip() for line in text.splitlines()]
    examples = [line for line in lines if line.startswith("qdensity ")
                and "[" not in line and not re.search(r"\b[A-Z]{2,}\b", line)]
    assert "qdensity demo --quick" in examples
    assert len(examples) >= 10, examples
    for line in examples:
        argv = shlex.split(line, comments=True)
        try:
            _parser().parse_args(argv[1:])
        except SystemExit as exc:  # a usage error (status 2)
            raise AssertionError(f"{line!r} from the page does not parse "
                                 f"(status {exc.code})") from None
    shown = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))
    known = _help_options()
    assert "--quick" in shown and "--qasm-version" in shown
    assert shown <= known, f"options on the page the parser does not have: {shown - known}"
