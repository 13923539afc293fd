"""``idle_core``: the machine's runnable threads now and its load average against its cores."""

from __future__ import annotations

import os
import sys

import pytest

from qdensity import cluster


@pytest.mark.parametrize("cores, running, load, idle", [
    (2, 1, 1.3, True),  # only the caller runs; its own minute of work is in the average
    (2, 2, 0.4, False),  # another thread runs now
    (2, 1, 2.4, False),  # busy on average: the moment is a gap
    (8, 5, 4.0, True),
    (8, 8, 4.0, False),
    (1, 1, 0.0, False),  # one core: the caller's
])
def test_idle_core_counts_runnable_threads_and_the_load(monkeypatch, cores, running, load,
                                                        idle):
    monkeypatch.setattr(os, "cpu_count", lambda: cores)
    monkeypatch.setattr(os, "getloadavg", lambda: (load, load, load))
    monkeypatch.setattr(cluster, "_runnable_threads", lambda: running)
    assert cluster.idle_core() is idle


@pytest.mark.parametrize("load, idle", [(0.9, True), (1.1, False)])
def test_without_a_runnable_count_the_load_average_decides(monkeypatch, load, idle):
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (load, load, load))
    monkeypatch.setattr(cluster, "_runnable_threads", lambda: None)
    assert cluster.idle_core() is idle


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/loadavg")
def test_the_runnable_count_is_read_from_proc_and_counts_the_caller():
    running = cluster._runnable_threads()
    assert running is not None and 1 <= running  # this thread runs, at least
