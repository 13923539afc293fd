"""Run file writers under a file-size limit in a child process (the shared harness of
``tests/test_atomic_writes.py`` and ``paper/tests/test_paper_atomic_writes.py``).

A test module defines ``WRITERS``: ``{name: (file name, writer)}``, where ``writer(path)``
writes ``path`` (and may be called again on the file it wrote). The child, for each writer in
a folder of its own, calls it once without a limit (that file is "the old file"), then lowers
``RLIMIT_FSIZE`` below every writer's output with ``SIGXFSZ`` ignored, so that a write past the
limit raises ``OSError`` (``EFBIG``) as a full disk would (``ENOSPC``), and calls each writer
again. It reports what each second call raised, whether the old file is byte for byte what it
was, and what else is in the folder (a temporary file left behind would show there).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Bytes a file may grow to under the limit: less than any writer's output.
LIMIT = 32


def run_writers(module: str, folder: Path, timeout: float = 600) -> dict:
    """Run ``module.WRITERS`` in a child process under the size limit; its report by name."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "paper"), str(ROOT / "tests"),
                                         str(ROOT / "paper" / "tests"),
                                         env.get("PYTHONPATH", "")])
    env.update(MPLBACKEND="Agg", TQDM_DISABLE="1")
    done = subprocess.run([sys.executable, "-m", "_atomic", module, str(folder)], env=env,
                          capture_output=True, text=True, timeout=timeout, cwd=folder)
    assert done.returncode == 0, done.stderr[-4000:]
    return json.loads(done.stdout.splitlines()[-1])


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _child(module: str, root: Path) -> dict:
    import resource
    import signal

    writers = importlib.import_module(module).WRITERS
    before = {}
    for i, (name, (file_name, writer)) in enumerate(writers.items()):
        folder = root / f"w{i}"
        folder.mkdir()
        path = folder / file_name
        writer(path)  # unlimited: the old file (and the imports done)
        before[name] = (path, path.read_bytes(), _listing(folder))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    report = {}
    for name, (_, writer) in writers.items():
        path, old, listing = before[name]
        resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, hard))
        try:
            writer(path)
            raised = None
        except BaseException as exc:  # noqa: BLE001 - reported to the parent
            raised = [type(exc).__name__, getattr(exc, "errno", None), str(exc)[:300]]
        finally:
            resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        report[name] = {"raised": raised, "old_size": len(old),
                        "intact": path.read_bytes() == old if path.exists() else False,
                        "listing_before": listing, "listing_after": _listing(path.parent)}
    return report


if __name__ == "__main__":
    print(json.dumps(_child(sys.argv[1], Path(sys.argv[2]))))


def assert_old_file_whole(got: dict, name: str) -> None:
    """What :func:`run_writers` recorded for writer ``name``: its write past the size limit
    failed with EFBIG, the old file is byte for byte as before, and no temporary file is left."""
    import errno

    assert got["old_size"] > 32  # the limit is below the file, so the write must fail
    assert got["raised"] is not None and got["raised"][1] == errno.EFBIG, got["raised"]
    assert got["intact"], f"{name}: the old file changed"
    assert got["listing_after"] == got["listing_before"]  # no temporary file left
