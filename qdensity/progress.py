"""Progress bars for long runs: tqdm on a terminal, silent everywhere else.

One helper for every layer (plan runs on a sampler, ``table1``, the demo, training, sweeps):
:func:`progress_bar` returns a ``tqdm`` bar that draws only when asked (``verbose=True``) *and*
its stream is a terminal (tqdm's ``disable=None`` rule), so runs under pytest, in a pipe, in a
notebook or in a log file print nothing. ``TQDM_DISABLE=1`` in the environment silences every
bar. One bar per phase (e.g. ``transpile``, then ``sample``); callers report what was spent with
``bar.set_postfix(...)`` (circuits, shots).

:func:`wait_for` waits on a primitive job (Qiskit ``BasePrimitiveJob`` or anything with
``done()`` and ``result()``) while keeping a bar's clock running, so a single long sampler call
shows that it is alive.
"""

from __future__ import annotations

import sys
import time
from typing import Protocol, TypeVar

from tqdm import tqdm

__all__ = ["progress_bar", "wait_for"]

_Result = TypeVar("_Result", covariant=True)


class _Job(Protocol[_Result]):
    """What :func:`wait_for` needs of a job: ``result()`` (``done()`` is looked up, optional)."""

    def result(self) -> _Result: ...


def progress_bar(total: int | None = None, *, desc: str = "", verbose: bool = True,
                 unit: str = "it", file=None, leave: bool = False, delay: float = 0.0,
                 **kwargs) -> tqdm:
    """A tqdm bar on a terminal when ``verbose``; a bar that does nothing otherwise.

    Parameters
    ----------
    total : int or None
        Expected number of updates (None: unknown).
    desc : str
        Prefix of the bar (the phase: ``"transpile"``, ``"sample"``, ``"table1"``, ...).
    verbose : bool
        False: never draw.
    unit : str
        What one update counts (``"circuit"``, ``"row"``, ``"step"``).
    file : text stream, optional
        Default ``sys.stderr``; the bar draws only if ``file.isatty()``.
    leave : bool
        Keep the finished bar on screen.
    delay : float
        Seconds before the bar first draws: runs shorter than this stay silent.
    **kwargs
        Passed to ``tqdm`` (``postfix``, ``position``, ...).

    Returns
    -------
    tqdm.tqdm
        Use ``update(n)``, ``set_postfix(...)`` and ``close()`` (or ``with``); ``bar.disable``
        says whether it is silent.

    Examples
    --------
    >>> import io
    >>> with progress_bar(3, desc="sample", unit="circuit", file=io.StringIO()) as bar:
    ...     bar.update(3)
    ...     bar.disable   # not a terminal: silent
    True
    """
    stream = sys.stderr if file is None else file
    return tqdm(total=total, desc=desc, unit=unit, file=stream, leave=leave, delay=delay,
                disable=None if verbose else True, dynamic_ncols=True, **kwargs)


def wait_for(job: _Job[_Result], bar: tqdm | None = None, *, poll: float = 0.2) -> _Result:
    """``job.result()``, refreshing ``bar`` (its elapsed time) until the job is done.

    Parameters
    ----------
    job : qiskit.primitives.BasePrimitiveJob
        Or anything with ``result()`` (and ``done()`` to poll; without it, just waits).
    bar : tqdm.tqdm, optional
        A bar from :func:`progress_bar`; nothing is polled when it is None or silent.
    poll : float
        Seconds between refreshes.

    Returns
    -------
    object
        The job's result, of the type its ``result()`` returns.

    Examples
    --------
    >>> class Done:
    ...     def done(self): return True
    ...     def result(self): return 42
    >>> wait_for(Done())
    42
    """
    done = getattr(job, "done", None)
    if bar is not None and not bar.disable and callable(done):
        while not done():
            time.sleep(poll)
            if time.time() - bar.start_t >= (bar.delay or 0.0):
                bar.refresh()
    return job.result()
