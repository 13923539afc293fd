"""Measure the README's timing table ("How long") and print it, or write it into README.md.

Usage, from the repository root: ``python benchmarks/readme_timings.py [--update] [--tests]``.
Each row's command runs once in a child process; the table gives its wall time, the load
average while it ran (1-minute, mean of start and end) and its CPU time (user + system of the
child and its children), which is about what an idle machine needs as wall time. ``--tests``
adds the test suite (``python -m pytest -n 2 -q``: minutes; without it the README's tests row
is kept as it is). ``--update`` rewrites the table's rows in README.md and the sentence above
it that says where it was measured.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
TESTS_LABEL = "the tests, `python -m pytest -n 2 -q`"


def _tour() -> str:
    """The README's first Python block (the tour), verbatim."""
    text = README.read_text(encoding="utf-8")
    return re.search(r"## A tour\n\n```python\n(.*?)```", text, re.S).group(1)


def _rows(with_tests: bool) -> list[tuple[str, list[str]]]:
    qd = [sys.executable, "-m", "qdensity.cli.main"]
    rows = [("`qdensity demo`", qd + ["demo"]),  # run in a temporary folder: the PNG goes there
            ("`qdensity demo --quick`", qd + ["demo", "--quick"]),
            ("the tour below (Python)", [sys.executable, "-c", _tour()]),
            ("`qdensity run --size 6 --target heavy_hex --shots 4000 --scheduler neyman`",
             qd + ["run", "--size", "6", "--target", "heavy_hex", "--shots", "4000",
                   "--scheduler", "neyman"]),
            ("`qdensity table1 --n 4 8 16 --json`", qd + ["table1", "--n", "4", "8", "16",
                                                        "--json"]),
            ("`qdensity table1 --n 4 8 16 32 64`", qd + ["table1", "--n", "4", "8", "16", "32",
                                                       "64"])]
    if with_tests:
        rows.append((TESTS_LABEL, [sys.executable, "-m", "pytest", "-n", "2", "-q"]))
    return rows


def measure(argv: list[str], cwd: str) -> tuple[float, float, float]:
    """``(wall seconds, mean 1-minute load, CPU seconds)`` of one run of ``argv``."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), TQDM_DISABLE="1", MPLBACKEND="Agg")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load0, t0 = os.getloadavg()[0], time.perf_counter()
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True)
    wall, load1 = time.perf_counter() - t0, os.getloadavg()[0]
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{argv[:4]} failed:\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, (load0 + load1) / 2, cpu


def _seconds(s: float) -> str:
    return f"{s / 60:.1f} min" if s >= 120 else (f"{s:.1f} s" if s < 10 else f"{s:.0f} s")


def machine() -> str:
    """Where this runs, in words: CPU model, cores, memory."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (OSError, ValueError):
        mem = float("nan")
    return f"{model}, {os.cpu_count()} cores, {mem:.0f} GB, Python {platform.python_version()}"


def sentence(where: str, tests: bool) -> str:
    """The README's line above the table: how and where it was measured."""
    text = (f"How long, measured by `python benchmarks/readme_timings.py` on {where}, with "
            f"other jobs sharing the machine: wall time at the 1-minute load average shown, "
            f"and CPU time, about what an idle machine needs as wall time"
            + ("" if tests else " (the tests row is an earlier measurement; `--tests` "
               "re-measures it)") + ":")
    return textwrap.fill(text, width=100, break_on_hyphens=False)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--update", action="store_true", help="write the table into README.md")
    parser.add_argument("--tests", action="store_true", help="also time the test suite")
    args = parser.parse_args(argv)
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, cmd in _rows(args.tests):
            wall, load, cpu = measure(cmd, tmp)
            lines.append(f"| {label} | {_seconds(wall)} ({load:.1f}) | {_seconds(cpu)} |")
            print(lines[-1], flush=True)
    where = machine()
    print(f"\nmeasured on {where}")
    if args.update:
        text = README.read_text(encoding="utf-8")
        head = "| command | wall (load) | CPU |\n|---|---|---|\n"
        start = text.index(head) + len(head)
        end = text.index("\n\n", start)
        old = text[start:end].splitlines()
        if not args.tests:  # keep the suite's row as it was measured before
            lines += [row for row in old if row.startswith(f"| {TESTS_LABEL}")]
        text = text[:start] + "\n".join(lines) + text[end:]
        text = re.sub(r"How long, measured [^|]*?:\n\n\|",
                      lambda m: sentence(where, args.tests) + "\n\n|", text, count=1,
                      flags=re.S)
        README.write_text(text, encoding="utf-8")
        print("README.md updated")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
