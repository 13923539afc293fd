"""Shared pytest configuration."""

from __future__ import annotations


def pytest_configure(config) -> None:
    """Silence scipy's SparseEfficiencyWarning, raised inside Qiskit's sparse ``expm`` when
    ``Operator`` evaluates a ``PauliEvolutionGate``; it says nothing about qdensity."""
    config.addinivalue_line("filterwarnings", "ignore::scipy.sparse.SparseEfficiencyWarning")


# Property tests are reproducible: every run (any pytest-randomly seed, any order, any
# machine) tries the same examples, and no example database carries state between runs.
# HYPOTHESIS_PROFILE=explore draws fresh examples for a local bug hunt.
from hypothesis import settings  # noqa: E402

settings.register_profile("qdensity", derandomize=True, database=None, deadline=None,
                          print_blob=True)
settings.register_profile("explore", derandomize=False, database=None, deadline=None,
                          print_blob=True)
settings.load_profile(__import__("os").environ.get("HYPOTHESIS_PROFILE", "qdensity"))
