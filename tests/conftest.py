"""Shared pytest configuration."""

from __future__ import annotations


def pytest_configure(config) -> None:
    """Silence scipy's SparseEfficiencyWarning, raised inside Qiskit's sparse ``expm`` when
    ``Operator`` evaluates a ``PauliEvolutionGate``; it says nothing about qdensity."""
    config.addinivalue_line("filterwarnings", "ignore::scipy.sparse.SparseEfficiencyWarning")
