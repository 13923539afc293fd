"""The hardware guide's "Real devices" block runs verbatim, on its own, in a fresh interpreter (it
once relied on names from an earlier block and put an 8-qubit model on a 5-qubit device)."""

import re
import subprocess
import sys
from pathlib import Path

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "guide" / "hardware.md"


def _block(heading: str) -> str:
    text = GUIDE.read_text()
    start = text.index(heading)
    match = re.compile(r"```python\n(.*?)```", re.S).search(text, start)
    assert match is not None, f"no python block after {heading!r}"
    nxt = text.find("\n## ", start + len(heading))
    assert nxt == -1 or match.start() < nxt, f"the python block is not under {heading!r}"
    return match.group(1)


def test_real_devices_block_runs_verbatim(tmp_path):
    code = _block("## Real devices")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "readout calibration" in out.stdout
    assert (tmp_path / "manila.json").is_file()
