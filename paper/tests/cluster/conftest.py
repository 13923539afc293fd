"""Shared by the paper's cluster tests: the toy experiments registered under their names."""

from __future__ import annotations

import pytest
from _toy import TOY, WHOLE

from qdensity_paper import registry


@pytest.fixture
def toys(monkeypatch):
    """``toy`` (a seed split into one unit per model) and ``toy-whole`` (a seed one unit)."""
    table = {"toy": TOY, "toy-whole": WHOLE}
    for name in table:
        monkeypatch.setitem(registry.EXPERIMENTS, name, name)
    real = registry.get_experiment
    monkeypatch.setattr(registry, "get_experiment", lambda name: table.get(name) or real(name))
    return table
