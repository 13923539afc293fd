"""mypy reads the documentation's Python examples as a user's scripts and resolves every import.

Every Python block of README.md and of docs/**/*.md (the blocks ``tests/test_readme.py`` runs)
is written to a file of its own and the files go through one mypy call, with the package's own
mypy settings (``[tool.mypy]`` of pyproject.toml: dependencies without type information are
ignored) and qdensity found as this tree's sources. A name an example imports from qdensity
that does not exist there (``import-not-found``, ``attr-defined``), or any other error mypy
finds in an example, fails the test: the examples are what users copy, with their editor's
type checker on.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from test_readme import PYTHON

ROOT = Path(__file__).resolve().parent.parent

pytest.importorskip("mypy", reason="the type check needs mypy: pip install -e '.[dev]'")


def _config(tmp_path: Path) -> Path:
    """pyproject's mypy settings for the examples: this tree's qdensity (and the paper's
    package, ``paper/qdensity_paper``, that the experiments' examples use) first on the path;
    ``follow_imports = silent`` reports errors in the examples, not in the package (which
    ``python -m mypy qdensity`` checks); qdensity's own imports must resolve."""
    config = tmp_path / "mypy.ini"
    config.write_text(
        "[mypy]\n"
        "python_version = 3.10\n"
        f"mypy_path = {ROOT}:{ROOT / 'paper'}\n"
        "follow_imports = silent\n"
        "check_untyped_defs = true\n"
        "no_implicit_optional = true\n"
        "[mypy-qiskit.*,qiskit_aer.*,qiskit_ibm_runtime.*,sklearn.*,mthree.*,mlxtend.*,"
        "dask_jobqueue.*,pennylane.*,optuna.*,torch.*]\n"
        "ignore_missing_imports = true\n"
        "[mypy-qdensity.*,qdensity_paper.*]\n"
        "ignore_missing_imports = false\n",
        encoding="utf-8")
    return config


def test_mypy_resolves_every_import_of_the_documented_examples(tmp_path):
    assert len(PYTHON) >= 8
    files = {}
    for i, (block, code) in enumerate(PYTHON):
        path = tmp_path / f"example_{i:03d}.py"
        path.write_text(code + "\n", encoding="utf-8")
        files[path.name] = block
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(_config(tmp_path)),
         "--cache-dir", str(ROOT / ".mypy_cache"), "--no-error-summary", "--show-error-codes",
         *sorted(str(p) for p in tmp_path.glob("example_*.py"))],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
        env=dict(os.environ, MYPYPATH=f"{ROOT}:{ROOT / 'paper'}"))
    errors = []
    for line in proc.stdout.splitlines():
        match = re.match(r".*?(example_\d+\.py):(\d+): error: (.*)", line)
        if match:
            errors.append(f"{files[match.group(1)]} line {match.group(2)}: {match.group(3)}")
    assert not errors, f"{len(errors)} mypy errors in the examples:\n" + "\n".join(errors)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]


def test_the_check_fails_on_a_name_qdensity_does_not_have(tmp_path):
    """The same check on a script that imports a name qdensity lacks and a module it lacks:
    mypy must report both (so the test above cannot pass by resolving nothing)."""
    script = tmp_path / "example_000.py"
    script.write_text("from qdensity import DensityQNN, NoSuchName\n"
                      "import qdensity.no_such_module\n"
                      "print(DensityQNN, NoSuchName, qdensity.no_such_module)\n",
                      encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(_config(tmp_path)),
         "--cache-dir", str(ROOT / ".mypy_cache"), "--show-error-codes", str(script)],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
        env=dict(os.environ, MYPYPATH=f"{ROOT}:{ROOT / 'paper'}"))
    assert proc.returncode == 1, proc.stdout
    assert "[attr-defined]" in proc.stdout and "NoSuchName" in proc.stdout
    assert "[import-not-found]" in proc.stdout and "no_such_module" in proc.stdout
