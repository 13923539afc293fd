"""A job handle for qdensity's own ``BaseSamplerV2`` implementations (public qiskit API only).

qiskit's ``PrimitiveJob`` is meant for qiskit's reference primitives and is started through a
private method; qiskit asks other implementers to subclass ``BasePrimitiveJob`` instead, which
:class:`LocalJob` does: the work runs on a thread of its own, started at construction.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from qiskit.primitives import BasePrimitiveJob
from qiskit.providers import JobStatus
from qiskit.providers.jobstatus import JOB_FINAL_STATES

__all__ = ["LocalJob"]


class LocalJob(BasePrimitiveJob):
    """``function(*args)`` running on a thread of its own; ``result()`` waits for it.

    Parameters
    ----------
    function : callable
        Returns the job's result (a ``PrimitiveResult``).
    *args
        Passed to ``function``.
    """

    def __init__(self, function: Callable, *args):
        super().__init__(str(uuid.uuid4()))
        executor = ThreadPoolExecutor(max_workers=1)
        self.future = executor.submit(function, *args)
        executor.shutdown(wait=False)

    def result(self):
        """The result, once the work is done (its exception, if it raised)."""
        return self.future.result()

    def status(self) -> JobStatus:
        """``RUNNING``, ``DONE``, ``CANCELLED`` or ``ERROR``."""
        if self.future.cancelled():
            return JobStatus.CANCELLED
        if not self.future.done():
            return JobStatus.RUNNING
        return JobStatus.DONE if self.future.exception() is None else JobStatus.ERROR

    def cancel(self) -> bool:
        """Cancel the work if it has not started."""
        return self.future.cancel()

    def done(self) -> bool:
        """Whether the work finished without an error."""
        return self.status() == JobStatus.DONE

    def running(self) -> bool:
        """Whether the work is still running."""
        return self.status() == JobStatus.RUNNING

    def cancelled(self) -> bool:
        """Whether the work was cancelled."""
        return self.status() == JobStatus.CANCELLED

    def in_final_state(self) -> bool:
        """Whether the job is done, cancelled or failed."""
        return self.status() in JOB_FINAL_STATES

    def __getstate__(self):
        state = self.__dict__.copy()
        state["result_value"] = self.result()
        state["future"] = None
        return state

    def __setstate__(self, state):
        value = state.pop("result_value")
        self.__dict__.update(state)
        from concurrent.futures import Future

        self.future = Future()
        self.future.set_result(value)
