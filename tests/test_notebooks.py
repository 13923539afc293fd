"""Every notebook in notebooks/ runs top to bottom (small settings), so none can rot.

The notebooks are jupytext percent scripts (``notebooks/*.py``: ``# %%`` opens a code cell,
``# %% [markdown]`` a markdown cell); jupytext reads them into notebooks and nbclient runs them
in a kernel, as the documentation build does. Where ``QDENSITY_DOCS_HTML`` names a site built
with the notebooks executed (``.ci/run``), a notebook is not run twice: the test reads the
notebook the build executed (``jupyter_execute/`` beside the HTML), after checking that its
code cells are those of the script as it is now.

A notebook whose optional extra is missing prints ``skipped: ... pip install ...`` and ends
cleanly; its test is then skipped with that install hint. The notebooks take minutes, so each
test says on the terminal which notebook runs (even under ``pytest -q``).
"""

import os
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

jupytext = pytest.importorskip("jupytext", reason="the notebooks are jupytext scripts: "
                               "pip install -e '.[dev]'")

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.py"))


def test_there_are_notebooks():
    assert len(NOTEBOOKS) == 13
    assert not list(NOTEBOOKS[0].parent.glob("*.ipynb"))  # one authoring format


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: f"notebook:{p.stem}")
def test_a_notebook_is_a_percent_script_with_a_title(path):
    nb = jupytext.read(path)
    assert nb.metadata["jupytext"]["text_representation"]["format_name"] == "percent"
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")
    assert any(c.cell_type == "code" for c in nb.cells)


def _text(output) -> str:
    text = output.get("text", "")
    return "".join(text) if isinstance(text, list) else str(text)


def _code(nb) -> list[str]:
    return [c.source.strip() for c in nb.cells if c.cell_type == "code"]


def _executed_by_the_docs_build(path: Path):
    """The notebook the documentation build executed from ``path``, or None."""
    site = os.environ.get("QDENSITY_DOCS_HTML")
    if not site:
        return None
    built = Path(site).parent / "jupyter_execute" / "notebooks" / f"{path.stem}.ipynb"
    if not built.is_file():
        return None
    nb = nbformat.read(built, as_version=4)
    assert _code(nb) == _code(jupytext.read(path)), f"{built} is stale: rebuild the site"
    return nb


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: f"notebook:{p.stem}")
def test_notebook_executes(path, capsys):
    nb = _executed_by_the_docs_build(path)
    if nb is None:
        with capsys.disabled():  # name what runs: a notebook takes up to a minute
            sys.stderr.write(f"\n[running notebooks/{path.name}] ")
            sys.stderr.flush()
        nb = jupytext.read(path)
        NotebookClient(nb, timeout=300, kernel_name="python3",
                       resources={"metadata": {"path": str(path.parent)}}).execute()
    assert all(c.get("execution_count") for c in nb.cells if c.cell_type == "code")
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    errors = [o for o in outputs if o.get("output_type") == "error"]
    assert not errors
    skipped = [line for o in outputs for line in _text(o).splitlines()
               if line.startswith("skipped:")]
    if skipped:
        assert all("pip install" in line for line in skipped), skipped
        pytest.skip(f"{path.name}: {skipped[0]}")


def test_a_missing_extra_skips_cleanly_with_an_install_hint(tmp_path):
    """The experiment notebooks' guard, run where torch cannot be imported."""
    nb = jupytext.read(NOTEBOOKS[0].parent / "experiment_pyramid_shots.py")
    block = nbformat.v4.new_code_cell(  # as if torch were not installed: its import fails
        "import sys\n"
        "class _NoTorch:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'torch' or name.startswith('torch.'):\n"
        "            raise ModuleNotFoundError(\"No module named 'torch'\", name='torch')\n"
        "sys.meta_path.insert(0, _NoTorch())")
    nb.cells.insert(0, block)
    NotebookClient(nb, timeout=120, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(_text(o) for o in outputs)
    assert "skipped:" in text and "pip install 'qdensity[torch]'" in text
