"""The execution layer beyond one process: Dask ``distributed``.

Sweeps (:func:`qdensity.learning.sweep.run_sweep`) and the paper's experiments (the separate
``qdensity_paper`` package) hand their units of work (one setting of one seed,
one sweep trial) to a Dask cluster named by an *address*:

* ``"local"`` or ``"local:N"``: a ``LocalCluster`` embedded in this process, ``N`` worker
  processes of one thread each on this machine (``"local"``: one per core);
* ``"tcp://HOST:PORT"``: a running scheduler (``dask scheduler``), its workers on any machines
  (``dask worker tcp://HOST:PORT``; see the README, "More than one machine");
* a ``distributed.Client`` the caller made (left open).

Everything a unit needs travels by pickle: the experiment's module-level functions by
reference (the workers import qdensity), settings and data by value.

Dask is an extra of the library: ``pip install 'qdensity[cluster]'``. Without it everything
else runs; a cluster address then raises an ``ImportError`` that says what to install.
"""

from __future__ import annotations

import logging
import os
import socket
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from qdensity.validation import CallableC, Instance, Interval, SequenceOf, validates

__all__ = ["CLUSTER_FORMS", "parse_cluster", "open_client", "run_units", "worker_name",
           "CONNECT_TIMEOUT", "IN_PROCESS", "idle_core"]

#: The forms a cluster address takes (error messages quote this).
#: Most worker processes ``local:N`` starts on one machine.
MAX_LOCAL_WORKERS = 256
CLUSTER_FORMS = ("'local' (one worker process per core), 'local:N' (N worker processes on this "
                 "machine), 'tcp://HOST:PORT' (a running dask scheduler) or a "
                 "distributed.Client")

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT = 10.0

#: What ``worker_name`` says outside a Dask worker.
IN_PROCESS = "in-process"


def idle_core() -> bool:
    """Whether this machine has a core that no other thread is using now.

    On Linux: fewer threads runnable at this moment than cores (``/proc/loadavg``'s count of
    runnable threads, the caller's own among them) and a 1-minute load average below the
    cores (the caller's own work is part of it). Elsewhere: 1-minute load average + 1 <=
    cores. (A load average alone counts the caller's own work: a process busy for a minute
    would see no idle core on two cores even with the second one free.)

    Threads inside one simulation or kernel pay only on idle cores: on a busy machine a
    parallel region waits for its slowest thread, and a thread waiting for a core made calls
    5-15x slower than one thread (measured at a load of 13 on 2 cores). Where the platform has
    no load average, True.

    Returns
    -------
    bool

    Examples
    --------
    How a caller picks its thread count:

    >>> threads = 2 if idle_core() else 1
    >>> threads in (1, 2)
    True
    """
    if not hasattr(os, "getloadavg"):  # pragma: no cover - Windows
        return True
    cores = os.cpu_count() or 1
    load = os.getloadavg()[0]
    running = _runnable_threads()
    if running is None:  # pragma: no cover - no /proc (macOS)
        return load + 1 <= cores
    return running < cores and load < cores


def _runnable_threads() -> int | None:
    """Threads runnable on the machine now (the 4th field of ``/proc/loadavg``, ``R/T``), or
    None where that file cannot be read."""
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            return int(f.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return None


@validates(cluster=Instance(str))
def parse_cluster(cluster: str) -> tuple[str, Any]:
    """Read a cluster address.

    Parameters
    ----------
    cluster : str
        ``"local"``, ``"local:N"`` (``N >= 1``) or ``"tcp://HOST:PORT"``.

    Returns
    -------
    tuple
        ``("local", N)`` (``N`` None for one worker per core) or ``("tcp", address)``.

    Raises
    ------
    ValueError, TypeError
        For any other form; the message lists the allowed ones.

    Examples
    --------
    >>> parse_cluster("local:4"), parse_cluster("tcp://10.0.0.5:8786")
    (('local', 4), ('tcp', 'tcp://10.0.0.5:8786'))
    """
    text = cluster.strip()
    if text == "local":
        return "local", None
    if text.startswith("local:"):
        count = text[len("local:"):]
        if count.isdigit() and 1 <= int(count) <= MAX_LOCAL_WORKERS:
            return "local", int(count)
        raise ValueError(f"cluster {cluster!r}: N in 'local:N' must be an int >= 1 and <= "
                         f"{MAX_LOCAL_WORKERS} (worker processes on this machine); allowed: "
                         f"{CLUSTER_FORMS}")
    if text.startswith("tcp://"):
        host, sep, port = text[len("tcp://"):].rpartition(":")
        if host and sep and port.isdigit() and 0 < int(port) < 65536:
            return "tcp", text
        raise ValueError(f"cluster {cluster!r}: expected tcp://HOST:PORT; allowed: "
                         f"{CLUSTER_FORMS}")
    raise ValueError(f"unknown cluster address {cluster!r}; allowed: {CLUSTER_FORMS}")


def _distributed():
    try:
        import distributed
    except ImportError as exc:
        raise ImportError("running on a Dask cluster needs the cluster extra: pip install "
                          "'qdensity[cluster]' (Dask's distributed)") from exc
    return distributed


@validates(
    cluster=[Instance(str), Instance('distributed:Client')],
    timeout=Interval(float, 0, 3600, closed='right'),
)
@contextmanager
def open_client(cluster, *, timeout: float = CONNECT_TIMEOUT) -> Iterator[Any]:
    """A ``distributed.Client`` for ``cluster`` (see the module docstring), closed on exit
    (with its ``LocalCluster``) unless the caller passed the client.

    Raises
    ------
    OSError
        When no scheduler answers at a ``tcp://`` address within ``timeout`` seconds; the
        message names the address.

    Examples
    --------
    An address is checked before anything starts:

    >>> with open_client("somewhere") as client:
    ...     pass
    Traceback (most recent call last):
        ...
    ValueError: unknown cluster address 'somewhere'; allowed: ...
    """
    distributed = _distributed()
    if isinstance(cluster, distributed.Client):
        yield cluster
        return
    kind, value = parse_cluster(cluster)
    if kind == "local":
        workers = value or os.cpu_count() or 1
        local = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                         processes=True, dashboard_address=":0",
                                         silence_logs=logging.ERROR)
        try:
            with distributed.Client(local) as client:
                yield client
        finally:
            local.close()
        return
    host, _, port = value[len("tcp://"):].rpartition(":")
    try:  # a refused port fails at once, not after the client's timeout
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
        client = distributed.Client(value, timeout=f"{float(timeout)}s")
    except (OSError, TimeoutError) as exc:
        raise OSError(f"cannot reach a dask scheduler at {value!r} within {timeout:g} s "
                      f"({type(exc).__name__}); start one with 'dask scheduler' and workers "
                      f"with 'dask worker {value}'") from None
    with client:
        yield client


def worker_name() -> str:
    """The address of the Dask worker running the caller, or ``"in-process"``.

    Examples
    --------
    >>> worker_name()  # outside a Dask worker
    'in-process'
    """
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return IN_PROCESS


def _call(fn: Callable, args: tuple) -> tuple[Any, str]:
    return fn(*args), worker_name()


@validates(
    client=Instance('distributed:Client'), fn=CallableC('a callable (picklable for the workers)'),
    arguments=SequenceOf(Instance(tuple), min_len=0), retries=Interval(int, 0, 100),
)
def run_units(client, fn: Callable, arguments: Sequence[tuple], *, retries: int = 2
              ) -> Iterator[tuple[int, Any, str]]:
    """Run ``fn(*args)`` for every ``args`` of ``arguments`` on the cluster; yield
    ``(index, result, worker address)`` as each finishes (in finishing order).

    A unit whose worker is lost is run again on another worker by the scheduler; one that
    raises is tried ``retries`` more times before its error is raised here.

    Examples
    --------
    On a client made by the caller (here in-process, one worker thread; ``open_client`` leaves it
    open):

    >>> import distributed
    >>> client = distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
    ...                             dashboard_address=None)
    >>> with open_client(client) as c:
    ...     done = sorted(run_units(c, pow, [(2, 3), (3, 2)]))
    >>> [(index, result) for index, result, _ in done]
    [(0, 8), (1, 9)]
    >>> client.close()
    """
    distributed = _distributed()
    futures = {client.submit(_call, fn, tuple(args), pure=False, retries=int(retries)): i
               for i, args in enumerate(arguments)}
    try:
        for future, (result, worker) in distributed.as_completed(futures, with_results=True):
            yield futures[future], result, worker
    finally:
        for future in futures:
            future.cancel()
