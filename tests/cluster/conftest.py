"""Shared by the cluster tests: a two-worker Dask cluster on loopback (started once), the toy
experiments registered under their names."""

from __future__ import annotations

import logging

import pytest
from _toy import TOY, WHOLE

from qdensity.experiments import registry


@pytest.fixture(scope="session")
def client():
    """A ``distributed.Client`` of a LocalCluster: two worker processes of one thread each on
    127.0.0.1."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None,
                                       silence_logs=logging.ERROR)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture
def toys(monkeypatch):
    """``toy`` (a seed split into one unit per model) and ``toy-whole`` (a seed one unit)."""
    table = {"toy": TOY, "toy-whole": WHOLE}
    for name in table:
        monkeypatch.setitem(registry.EXPERIMENTS, name, name)
    real = registry.get_experiment
    monkeypatch.setattr(registry, "get_experiment", lambda name: table.get(name) or real(name))
    return table
