"""Every notebook in notebooks/ runs top to bottom (small settings), so none can rot.

A notebook whose optional extra is missing prints ``skipped: ... pip install ...`` and ends
cleanly; its test is then skipped with that install hint. The notebooks take minutes, so each
test says on the terminal which notebook runs (even under ``pytest -q``).
"""

import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))


def test_there_are_notebooks():
    assert NOTEBOOKS


def _text(output) -> str:
    text = output.get("text", "")
    return "".join(text) if isinstance(text, list) else str(text)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: f"notebook:{p.stem}")
def test_notebook_executes(path, capsys):
    with capsys.disabled():  # name what runs: a notebook takes up to a minute
        sys.stderr.write(f"\n[running notebooks/{path.name}] ")
        sys.stderr.flush()
    nb = nbformat.read(path, as_version=4)
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
    nb = nbformat.read(NOTEBOOKS[0].parent / "experiment_pyramid_shots.ipynb", as_version=4)
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
