"""The wheel and the sdist, built from this tree, carry what a release needs and nothing stray.

Both are built once per module into a temporary folder with ``python -m build
--no-isolation`` (the sdist first, then the wheel from the unpacked sdist, so the sdist is shown
to be enough to build from; the backend, setuptools >= 77, comes with the dev install), and
their file lists are read with ``zipfile`` / ``tarfile``.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytest.importorskip("build", reason="needs the 'build' package of the dev extra: "
                    "pip install -e '.[dev]'")


@pytest.fixture(scope="module")
def dists(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out),
                           str(ROOT)],
                          capture_output=True, text=True, timeout=600, cwd=out)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    (wheel,) = out.glob("*.whl")
    (sdist,) = out.glob("*.tar.gz")
    with zipfile.ZipFile(wheel) as zf:
        wheel_names = zf.namelist()
        (meta,) = [n for n in wheel_names if n.endswith(".dist-info/METADATA")]
        metadata = zf.read(meta).decode()
    with tarfile.open(sdist) as tf:  # names without the leading "qdensity-VERSION/"
        sdist_names = [m.name.split("/", 1)[1] for m in tf.getmembers()
                       if m.isfile() and "/" in m.name]
    return {"wheel": wheel_names, "sdist": sdist_names, "log": proc.stdout + proc.stderr,
            "metadata": metadata}


def test_the_build_raises_no_license_deprecation(dists):
    log = dists["log"]
    assert "License classifiers are deprecated" not in log
    assert "project.license` as a TOML table is deprecated" not in log


def test_the_wheel_carries_the_package_its_types_and_its_license(dists):
    names = dists["wheel"]
    assert "qdensity/__init__.py" in names
    assert "qdensity/py.typed" in names
    assert "qdensity/execution/unary/__init__.py" in names  # sub-packages are found
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), names
    assert not [n for n in names if n.startswith(("tests/", "benchmarks/", "notebooks/",
                                                  "docs/"))]


def test_the_wheel_metadata_states_the_spdx_license_and_urls(dists):
    text = dists["metadata"]
    assert "License-Expression: Apache-2.0" in text
    assert "License-File: LICENSE" in text
    assert "Project-URL: Paper, https://arxiv.org/abs/2405.20237" in text
    assert "Classifier: Typing :: Typed" in text


def test_the_sdist_carries_the_release_files_and_no_stray_tests(dists):
    names = set(dists["sdist"])
    for required in ("LICENSE", "CITATION.cff", "CHANGELOG.md", "README.md", "pyproject.toml",
                     "qdensity/__init__.py", "qdensity/py.typed", "PKG-INFO"):
        assert required in names, required
    # the tests live in the repository (their fixtures in its root conftest.py): none in the sdist
    assert not [n for n in names if n.startswith("tests/")]
    assert not [n for n in names if n.startswith(("benchmarks/", "notebooks/", "docs/",
                                                  "results/", "paper/"))]
    assert "conftest.py" not in names
    assert not [n for n in names if n.endswith((".pyc", ".ipynb"))]


def test_the_package_version_matches_the_citation_file():
    version = re.search(r'^version = "([^"]+)"', (ROOT / "pyproject.toml").read_text(),
                        re.MULTILINE).group(1)
    citation = (ROOT / "CITATION.cff").read_text()
    assert f"version: {version}" in citation
    assert "preferred-citation:" in citation and "2405.20237" in citation
    assert (ROOT / "LICENSE").read_text().lstrip().startswith("Apache License")
    assert "END OF TERMS AND CONDITIONS" in (ROOT / "LICENSE").read_text()
