"""Every code block of README.md and of the documentation's Markdown pages (docs/**/*.md), as
they hold it when the tests run, so no example on the front page or the site goes untested.

Python blocks (fenced ```` ```python ```` and indented blocks that parse as Python) run
verbatim, each alone in a fresh interpreter, so a block that leans on names from an earlier
one fails. A block that imports an optional extra which is not installed is skipped, naming
the extra. Shell blocks: every ``qdensity ...`` line parses with the real command-line parser
(its options exist and their values are allowed; nothing is run: some take hours), and every
``python benchmarks/...`` script exists.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import re
import shlex
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
#: The pages whose code blocks run: the front page and the documentation's Markdown sources.
PAGES = [README, *sorted((ROOT / "docs").rglob("*.md"))]

#: Blocks known not to run alone, by the SHA-256 (first 16 hex digits) of their exact text: an
#: xfail that lapses as soon as the block's text changes (then the block must run).
KNOWN_BROKEN: dict[str, str] = {}

#: Top-level module an example may import -> the extra that brings it.
EXTRAS = {"torch": "torch", "optuna": "sweep", "qiskit_ibm_runtime": "ibm", "mthree": "ibm",
          "pennylane": "interop", "qiskit_machine_learning": "interop"}

#: Top-level module an example may import that no extra brings (documented for clusters only).
OTHER_PACKAGES = {"dask_jobqueue": "dask-jobqueue"}


def _blocks(page: Path = README) -> list[tuple[str, str, str]]:
    """``(id, kind, code)`` for every code block of ``page``: kind ``python`` or ``shell``; ids
    of a documentation page start with its path under ``docs/``."""
    lines = page.read_text(encoding="utf-8").splitlines()
    prefix = "" if page == README else \
        page.relative_to(ROOT / "docs").with_suffix("").as_posix().replace("/", "-") + ":"
    out, heading, i = [], "top", 0
    counts: dict[str, int] = {}

    def add(kind, code):
        slug = re.sub(r"[^a-z0-9]+", "-", heading.lower()).strip("-") or "top"
        counts[slug] = counts.get(slug, 0) + 1
        out.append((f"{prefix}{slug}-{counts[slug]}", kind, code))

    while i < len(lines):
        line = lines[i]
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        if line.startswith("```"):
            lang = line[3:].strip()  # a MyST directive ("{toctree}") or "text" is not code
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            code = "\n".join(lines[i + 1:j])
            if lang == "python":
                add("python", code)
            elif lang in ("", "sh", "bash", "shell", "console"):
                add("shell", code)
            i = j + 1
            continue
        if line.startswith("    ") and (i == 0 or not lines[i - 1].strip()):
            j = i
            while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
                j += 1
            code = textwrap.dedent("\n".join(lines[i:j])).strip("\n")
            try:
                ast.parse(code)
                python = not code.lstrip().startswith(("qdensity ", "python", "pip ", "./"))
            except SyntaxError:
                python = False
            add("python" if python else "shell", code)
            i = j
            continue
        i += 1
    return out


BLOCKS = [block for page in PAGES for block in _blocks(page)]
PYTHON = [(b, code) for b, kind, code in BLOCKS if kind == "python"]
SHELL = [(b, code) for b, kind, code in BLOCKS if kind == "shell"]


def test_the_readme_has_python_and_shell_blocks():
    readme = _blocks(README)
    assert any(kind == "python" for _, kind, _ in readme)
    assert sum(kind == "shell" for _, kind, _ in readme) >= 2
    assert len(PYTHON) >= 8 and len(SHELL) >= 10  # the site's pages carry the rest


def _missing_extra(code: str) -> str | None:
    for node in ast.walk(ast.parse(code)):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and node.module else [])
        for name in names:
            top = name.split(".")[0]
            if top in EXTRAS and importlib.util.find_spec(top) is None:
                return f"needs the {EXTRAS[top]!r} extra: pip install 'qdensity[{EXTRAS[top]}]'"
            if top in OTHER_PACKAGES and importlib.util.find_spec(top) is None:
                return f"needs {OTHER_PACKAGES[top]} (no extra brings it): pip install " \
                       f"{OTHER_PACKAGES[top]}"
    return None


@pytest.mark.parametrize(("block", "code"), PYTHON, ids=[b for b, _ in PYTHON])
def test_python_block_runs_verbatim_and_alone(block, code, tmp_path):
    reason = _missing_extra(code)
    if reason:
        pytest.skip(reason)
    broken = KNOWN_BROKEN.get(hashlib.sha256(code.encode()).hexdigest()[:16])
    if broken:
        pytest.xfail(broken)
    env = {"PYTHONPATH": str(ROOT), "TQDM_DISABLE": "1", "MPLBACKEND": "Agg",
           "OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"block {block} failed:\n{proc.stderr[-3000:]}"


def _commands(code: str) -> list[list[str]]:
    out = []
    for raw in code.replace("\\\n", " ").splitlines():  # a line continued by a backslash
        for part in raw.split("&&"):
            text = part.split("  #")[0].split(" # ")[0].strip()
            if text:
                out.append(shlex.split(text))
    return out


@pytest.mark.parametrize(("block", "code"), SHELL, ids=[b for b, _ in SHELL])
def test_shell_block_commands_exist_and_parse(block, code):
    from qdensity.cli.main import _parser

    for argv in _commands(code):
        if argv[0] == "qdensity":
            try:
                _parser().parse_args(argv[1:])
            except SystemExit as exc:  # a usage error (status 2)
                raise AssertionError(f"block {block}: {' '.join(argv)!r} does not "
                                     f"parse (status {exc.code})") from None
        elif argv[0] == "python" and len(argv) > 1 and argv[1].endswith(".py"):
            assert (ROOT / argv[1]).is_file(), f"block {block}: no {argv[1]}"
