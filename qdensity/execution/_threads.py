"""Threads of the compiled engines: blocks of independent work in a shared pool.

Both engines split work that has no dependencies between its parts into contiguous blocks and
run each block through the same compiled kernel in one thread (the caller's thread among
them); the kernels release the GIL.

* The unary engine (:mod:`qdensity.execution.unary`) cuts a wide batch into blocks of columns,
  each run through the whole circuit; the cosines, sines and nonzeros before it are computed
  in slices the same way. Without numba (or with ``QDENSITY_NUMBA=0``) its forward pass with
  angles shared by the batch is one compiled sparse product per two layers (``scipy``'s CSR
  kernel, which also releases the GIL), threaded the same way.
* The adjoint engine (:mod:`qdensity.execution.statevector`) cuts its parameter rows into
  blocks, each running the forward or the backward sweep of its rows.

Every number goes through the same machine code in the same order as in one thread, so the
results are bit-for-bit those of the single-threaded path (but for the unary engine's summed
parameter gradient, which adds the blocks' partial sums). Small work stays in the caller's
thread: below about ``MIN_WORK`` multiply-adds per thread (the unary engine; the adjoint
engine has its own threshold), handing work to another thread costs more than it saves.

Threads: the usable cores (``os.sched_getaffinity``, else ``os.cpu_count()``), at most
``MAX_THREADS``; the environment variable ``QDENSITY_NUM_THREADS`` overrides it (``1``: never
use threads; read at every call, so it may be set at run time; not an integer >= 1 raises
``ValueError``). Nothing here uses numpy's BLAS threads (the CSR kernel is a plain loop), so
these threads do not multiply with an ``OPENBLAS_NUM_THREADS`` / ``OMP_NUM_THREADS`` setting
(a unary batch wider than ``n`` ends in one ``O @ X`` product, which is BLAS's), nor with
numba's own thread pool, which these engines do not use. They are no help
on cores that other processes keep busy: when several processes share the cores
(multiprocessing, a loaded machine), set ``QDENSITY_NUM_THREADS=1``. The worker threads
live in one lazily created ``ThreadPoolExecutor`` (created again after a ``fork``).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__: list[str] = []

ENV = "QDENSITY_NUM_THREADS"
MAX_THREADS = 8  # default cap (the environment variable may ask for more)
# Multiply-adds per thread below which the work stays in one thread. Measured on a shared
# 2-core box (round-robin circuits, batch 64, forward with 2 threads against 1): in windows
# where other processes left the second core mostly free, 1.40x at n = 512 (1.7e7 per thread)
# and 1.45x at n = 1024 (6.7e7), but 0.67x at n = 128 (1.0e6); under load (the second core
# busy) only n = 1024 gained (~1.2x). Since the gates' sines and cosines are computed in the
# threads too: 1.14x at n = 256 (4.2e6 per thread; 0.48-0.65 against 0.61-0.66 ms, four
# quiet runs), 0.92-1.0x at n = 192 (2.3e6).
MIN_WORK = 4_000_000  # n = 256, batch 64: 2 threads; n = 192: 1
MIN_COLUMNS = 4  # narrowest column block

_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pool_key: tuple[int, int] = (0, 0)  # (pid, workers) of _pool
_cores: int | None = None
_parsed: tuple[object, int] = (object(), 0)  # the variable's last value read, and its count


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS tells it)."""
    global _cores
    if _cores is None:
        try:
            _cores = len(os.sched_getaffinity(0))
        except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
            _cores = os.cpu_count() or 1
    return max(1, _cores)


def num_threads() -> int:
    """Threads the kernels may use: ``QDENSITY_NUM_THREADS`` or the usable cores (capped)."""
    global _parsed
    raw = os.environ.get(ENV)
    if raw == _parsed[0]:
        return _parsed[1]
    if raw is None or not raw.strip():
        value = min(usable_cores(), MAX_THREADS)
    else:
        try:
            value = int(raw.strip())
        except ValueError:
            value = 0
        if value < 1:
            raise ValueError(f"{ENV} must be an integer >= 1 (1 disables the unary engine's "
                             f"threads), got {raw!r}")
    _parsed = (raw, value)
    return value


def blocks(columns: int, work_per_column: int) -> list[tuple[int, int]]:
    """Contiguous column ranges ``[lo, hi)``, one per thread (one range: no threads)."""
    k = num_threads()
    if k > 1:
        k = min(k, columns // MIN_COLUMNS, work_per_column * columns // max(MIN_WORK, 1))
    if k <= 1:
        return [(0, columns)]
    return split(columns, k)


def split(size: int, k: int) -> list[tuple[int, int]]:
    """``[0, size)`` cut into ``k`` contiguous ranges ``[lo, hi)`` of near-equal length."""
    edges = [size * i // k for i in range(k + 1)]
    return list(zip(edges[:-1], edges[1:], strict=True))


def _executor(workers: int) -> ThreadPoolExecutor:
    """The pool (threads are started on demand, up to its size). A pool too small for
    ``workers`` is replaced, not shut down: calls already holding it finish on it."""
    global _pool, _pool_key
    with _lock:
        pid = os.getpid()
        if _pool is None or _pool_key[0] != pid or _pool_key[1] < workers:
            size = max(workers, 2 * MAX_THREADS)
            _pool = ThreadPoolExecutor(size, thread_name_prefix="qdensity-unary")
            _pool_key = (pid, size)
        return _pool


def run_blocks(fn, ranges: list[tuple[int, int]]) -> None:
    """``fn(lo, hi)`` for every range, shared out among the caller and pool threads.

    Each thread (the caller included) takes ranges from a common list until it is empty, and
    the caller returns once every range is done: a pool thread that starts late (a busy
    machine) finds nothing left and nobody waits for it.
    """
    if len(ranges) == 1:
        fn(*ranges[0])
        return
    todo = list(reversed(ranges))
    left = [len(ranges)]
    lock, done, errors = threading.Lock(), threading.Event(), []

    def work():
        while True:
            with lock:
                if not todo:
                    return
                lo, hi = todo.pop()
            try:
                fn(lo, hi)
            except BaseException as exc:  # raised in the caller's thread
                errors.append(exc)
            with lock:
                left[0] -= 1
                if not left[0]:
                    done.set()

    pool = _executor(len(ranges) - 1)
    for _ in range(len(ranges) - 1):
        pool.submit(work)
    work()
    done.wait()
    if errors:
        raise errors[0]
