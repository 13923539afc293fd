"""Every notebook in notebooks/ runs top to bottom (small settings), so none can rot.

The notebooks are jupytext percent scripts (``notebooks/*.py``: ``# %%`` opens a code cell,
``# %% [markdown]`` a markdown cell); jupytext reads them into notebooks and nbclient runs them
in a kernel, as the documentation build does.

A notebook whose optional extra is missing prints ``skipped: ... pip install ...`` and ends
cleanly; its test is then skipped with that install hint. The notebooks take minutes, so each
test says on the terminal which notebook runs (even under ``pytest -q``).
"""

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


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: f"notebook:{p.stem}")
def test_notebook_executes(path, capsys):
    with capsys.disabled():  # name what runs: a notebook takes up to a minute
        sys.stderr.write(f"\n[running notebooks/{path.name}] ")
        sys.stderr.flush()
    nb = jupytext.read(path)
    NotebookClient(nb, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
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
