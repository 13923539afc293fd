"""A sampled job's result that keeps its shots packed (8 clbits a byte, as qiskit's
``BitArray``) and unpacks ``bits`` when read.

A density gradient at device widths holds every job's shots until its post-processing reads
them, one sub-unitary at a time: at ``n = 256`` (510 jobs of 16 rows x 1,000 shots) the
unpacked booleans would take 2.1 GB, the packed bytes 0.26 GB. The unpacked array is kept
only while a caller holds it (a weak reference), so reading ``bits`` twice in a row costs one
unpacking and nothing stays allocated after the caller lets go.
"""

from __future__ import annotations

import weakref

import numpy as np

from qdensity.execution.job_results import JobResult


class PackedJobResult(JobResult):
    """:class:`~qdensity.execution.job_results.JobResult` whose ``bits`` are unpacked on read.

    Parameters
    ----------
    packed : qiskit.primitives.BitArray
        ``rows * shots`` samples (shape ``(rows,)`` or ``()``, see
        :func:`~qdensity.execution.sampler.engine.bitarray_to_bits`).
    rows, shots : int
    job : CircuitJob
    """

    def __init__(self, packed, rows: int, shots: int, job=None, **kwargs):
        self._packed = (packed, int(rows), int(shots))
        self._unpacked = None
        super().__init__(None, shots, job, bits=packed, **kwargs)

    @property
    def bits(self) -> np.ndarray:
        """numpy.ndarray of bool, shape (rows, shots, num_clbits), unpacked on read."""
        from qdensity.execution.sampler.engine import bitarray_to_bits

        held = self._unpacked() if self._unpacked is not None else None
        if held is None:
            held = bitarray_to_bits(*self._packed)
            self._unpacked = weakref.ref(held)
        return held

    @bits.setter
    def bits(self, value) -> None:  # JobResult.__init__ stores the packed form
        if value is not self._packed[0]:
            raise AttributeError("a PackedJobResult's bits are read from its packed shots")

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_unpacked"] = None
        return state
