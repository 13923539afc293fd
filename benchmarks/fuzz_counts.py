"""Run the fuzzers (tests/fuzz) and print how many inputs they tried per public entry point.

Usage: ``python benchmarks/fuzz_counts.py`` from the repository root. Bad inputs are counted
by ``_fuzz.refused`` (each must raise ValueError/TypeError), valid ones by ``_fuzz.accepted``
(each meets an independent oracle). Hypothesis runs derandomised, so the counts repeat.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "counts.json")
        env = dict(os.environ, QDENSITY_FUZZ_COUNTS=path)
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:randomly",
                               "-p", "no:xdist", "tests/fuzz"], env=env)
        with open(path, encoding="utf-8") as fh:
            counts = json.load(fh)
    bad = {k: v for k, v in counts.items() if not k.endswith("(valid)")}
    good = {k[: -len(" (valid)")]: v for k, v in counts.items() if k.endswith("(valid)")}
    print(f"\n{'entry point':<34}{'bad inputs':>12}{'valid inputs':>14}")
    for key in sorted(set(bad) | set(good)):
        print(f"{key:<34}{bad.get(key, 0):>12}{good.get(key, 0):>14}")
    print(f"{'total':<34}{sum(bad.values()):>12}{sum(good.values()):>14}")
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main())
