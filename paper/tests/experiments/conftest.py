"""Shared by the experiments' tests: a run at a tiny size with the invariants every experiment
must keep (seeds recorded, one metrics row per seed, every interval around its mean, the JSON
and PNG files written)."""

import json
from pathlib import Path

import pytest

from qdensity_paper import run

PNG = b"\x89PNG\r\n\x1a\n"


def _checked_run(name: str, config: dict, seeds: list[int], out: Path):
    result = run(name, config=config, seeds=seeds, out=out, progress=False)
    assert result.seeds == list(seeds) and len(result.per_seed) == len(seeds)
    for key, s in result.summary.items():
        assert s["n"] == len(seeds) and s["low"] - 1e-9 <= s["mean"] <= s["high"] + 1e-9, key
    for key, c in result.curves.items():
        bands = zip(c["low"], c["mean"], c["high"], strict=True)
        assert all(lo - 1e-9 <= m <= hi + 1e-9 for lo, m, hi in bands), key
    saved = json.loads((Path(out) / f"{name}-{result.mode}.json").read_text())
    assert saved["seeds"] == list(seeds) and saved["name"] == name
    assert saved["figures"] == result.figures and result.figures
    for path in result.figures:
        assert "/" not in path and (out / path).read_bytes()[:8] == PNG, path  # a name
    return result


@pytest.fixture(scope="session")
def checked_run():
    """``checked_run(name, config, seeds, out)``: :func:`qdensity_paper.run` plus the
    shared invariants; returns the result."""
    return _checked_run
