"""Seeds of the statistical tests: each test's own default, or ``QDENSITY_STAT_SEED`` when set
(``benchmarks/fuzz_statistics.py`` runs every statistical test over 50 seeds with it)."""

from __future__ import annotations

import os


def stat_seed(default: int) -> int:
    """``default``, or ``QDENSITY_STAT_SEED`` when set (read at call time)."""
    return int(os.environ.get("QDENSITY_STAT_SEED", default))
