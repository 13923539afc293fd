"""A sampled job's result that keeps its shots packed (8 clbits a byte, as qiskit's
``BitArray``) and unpacks ``bits`` when read.

A density gradient at device widths holds every job's shots until its post-processing reads
them, one sub-unitary at a time, as sparse set clbits (``set_clbits``, read off the packed
bytes by :func:`packed_set_bits`): at ``n = 256`` (510 jobs of 16 rows x 1,000 shots) the
unpacked booleans would take 2.1 GB, the packed bytes 0.26 GB. The unpacked array is kept
only while a caller holds it (a weak reference), so reading ``bits`` twice in a row costs one
unpacking and nothing stays allocated after the caller lets go. :func:`bitarray_to_bits` and
:func:`bitarray_to_probabilities` (exported by :mod:`qdensity.execution.sampler.engine`) read
any ``BitArray``.
"""

from __future__ import annotations

import weakref

import numpy as np
from qiskit.primitives import BitArray

from qdensity.execution.job_results import JobResult, bits_to_probabilities
from qdensity.validation import MAX_ROWS, MAX_SHOTS, Instance, Interval, validates


@validates(
    bitarray=Instance('qiskit.primitives:BitArray'), rows=Interval(int, 1, MAX_ROWS),
    shots=[Interval(int, 1, MAX_SHOTS), None],
)
def bitarray_to_bits(bitarray, rows: int, shots: int | None = None) -> np.ndarray:
    """The measured bits of a ``BitArray`` holding ``rows * shots`` samples.

    Parameters
    ----------
    bitarray : qiskit.primitives.BitArray
        Shape ``(rows,)`` with ``shots`` each, or shape ``()`` with ``rows * shots`` samples
        (consecutive blocks of ``shots`` form the rows).
    rows : int
    shots : int, optional
        Shots per row (default ``bitarray.num_shots``).

    Returns
    -------
    numpy.ndarray of bool, shape (rows, shots, num_bits)
        Column ``j`` is clbit ``j``; ``rows * shots * num_bits`` bytes, never ``2**num_bits``.

    Examples
    --------
    Four samples (bitstrings read clbit 0 rightmost) split into 2 rows of 2 shots:

    >>> from qiskit.primitives import BitArray
    >>> from qdensity.execution.engines import bitarray_to_bits
    >>> samples = BitArray.from_samples(["01", "10", "11", "11"], num_bits=2)
    >>> bitarray_to_bits(samples, rows=2, shots=2).astype(int).tolist()
    [[[1, 0], [0, 1]], [[1, 1], [1, 1]]]
    """
    shots = bitarray.num_shots if shots is None else int(shots)
    return _unpacked(np.asarray(bitarray.array), rows, shots, bitarray.num_bits)


@validates(
    bitarray=Instance('qiskit.primitives:BitArray'), rows=Interval(int, 1, MAX_ROWS),
    shots=[Interval(int, 1, MAX_SHOTS), None],
)
def bitarray_to_probabilities(bitarray, rows: int, shots: int | None = None) -> np.ndarray:
    """Empirical outcome frequencies from a ``BitArray`` holding ``rows * shots`` samples.

    Parameters
    ----------
    bitarray : qiskit.primitives.BitArray
        Shape ``(rows,)`` with ``shots`` each, or shape ``()`` with ``rows * shots`` samples
        (consecutive blocks of ``shots`` form the rows).
    rows : int
    shots : int, optional
        Shots per row (default ``bitarray.num_shots``).

    Returns
    -------
    numpy.ndarray, shape (rows, 2**num_bits)

    Raises
    ------
    ValueError
        Above ``MAX_DENSE_QUBITS`` (24) bits; use :func:`bitarray_to_bits`.

    Examples
    --------
    >>> from qiskit.primitives import BitArray
    >>> from qdensity.execution.engines import bitarray_to_probabilities
    >>> samples = BitArray.from_samples(["01", "10", "11", "11"], num_bits=2)  # outcomes 1,2,3,3
    >>> bitarray_to_probabilities(samples, rows=2, shots=2).tolist()
    [[0.0, 0.5, 0.5, 0.0], [0.0, 0.0, 0.0, 1.0]]
    """
    return bits_to_probabilities(bitarray_to_bits(bitarray, rows, shots))


def _unpacked(packed: np.ndarray, rows: int, shots: int, num_bits: int) -> np.ndarray:
    """``BitArray`` bytes (``rows * shots`` shots) as bool (rows, shots, num_bits)."""
    arr = packed.reshape(rows, shots, -1)
    # BitArray bytes are big-endian: the last byte holds clbits 0..7, its lowest bit clbit 0
    bits = np.unpackbits(arr[..., ::-1], axis=-1, bitorder="little")
    return bits[..., :num_bits].astype(bool)


def packed_set_bits(packed: np.ndarray, num_bits: int) -> tuple[np.ndarray, np.ndarray]:
    """``(shot, clbit)`` of the set bits of ``BitArray`` bytes ``packed`` (shots, nbytes)
    (big-endian: the last byte holds clbits 0..7), shot ascending, clbits below ``num_bits``.

    The bytes are read as little-endian 64-bit words (zero bytes in front make up the last
    word); the set bits of the nonzero words are peeled off lowest first (``v & -v``, its
    position an exact ``log2``), one vectorised pass per bit a word holds: a shot of Hamming
    weight ``k`` costs its ``nbytes / 8`` words plus ``k`` bits, never ``8 nbytes`` bits."""
    shots, nbytes = packed.shape
    pad = -nbytes % 8
    words = np.zeros((shots, (nbytes + pad) // 8), np.dtype("<u8"))
    words.view(np.uint8)[:, pad:] = packed  # byte j of the row is byte j + pad here
    flat = np.flatnonzero(words)
    value = words.ravel()[flat]
    shot_parts, byte_parts = [], []
    while flat.size:
        low = value & (~value + np.uint64(1))  # the lowest set bit
        pos = np.log2(low.astype(np.float64)).astype(np.int64)  # exact for powers of two
        shot_parts.append(flat)
        byte_parts.append((flat % words.shape[1]) * 64 + pos)  # bit index in the padded row
        value = value ^ low
        more = value != 0
        flat, value = flat[more], value[more]
    if not shot_parts:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    word_flat = np.concatenate(shot_parts)
    bit = np.concatenate(byte_parts)  # byte = bit // 8 (padded), bit % 8 inside the byte
    shot = word_flat // words.shape[1]
    clbit = (nbytes - 1 - (bit // 8 - pad)) * 8 + bit % 8
    order = np.argsort(shot, kind="stable")
    shot, clbit = shot[order], clbit[order]
    keep = clbit < num_bits
    return (shot, clbit) if keep.all() else (shot[keep], clbit[keep])


class PackedJobResult(JobResult):
    """:class:`~qdensity.execution.job_results.JobResult` whose ``bits`` are unpacked on read.

    Parameters
    ----------
    packed : qiskit.primitives.BitArray or DeferredSamples
        ``rows * shots`` samples (shape ``(rows,)`` or ``()``, see :func:`bitarray_to_bits`),
        or a :class:`~qdensity.execution.samplers.hamming.DeferredSamples` that draws them
        when read (the same shots on every read).
    rows, shots : int
    job : CircuitJob
    """

    def __init__(self, packed, rows: int, shots: int, job=None, **kwargs):
        self._packed = (packed, int(rows), int(shots))
        self._unpacked: weakref.ReferenceType[np.ndarray] | None = None
        super().__init__(None, shots, job, bits=packed, **kwargs)

    def _bytes(self) -> np.ndarray:
        """The shots' ``BitArray`` bytes, (rows * shots, nbytes); drawn now if deferred."""
        source, rows, shots = self._packed
        if isinstance(source, BitArray):
            return np.asarray(source.array).reshape(rows * shots, -1)
        return source.packed()

    @property
    def bits(self) -> np.ndarray:
        """numpy.ndarray of bool, shape (rows, shots, num_clbits), unpacked on read."""
        held = self._unpacked() if self._unpacked is not None else None
        if held is None:
            source, rows, shots = self._packed
            held = _unpacked(self._bytes(), rows, shots, source.num_bits)
            self._unpacked = weakref.ref(held)
        return held

    @bits.setter
    def bits(self, value) -> None:  # JobResult.__init__ stores the packed form
        if value is not self._packed[0]:
            raise AttributeError("a PackedJobResult's bits are read from its packed shots")

    @property
    def has_bits(self) -> bool:
        """True: sampled shots (held packed; ``bits`` would unpack them)."""
        return True

    @property
    def bits_shape(self) -> tuple[int, int, int]:
        """``(rows, shots, num_clbits)``, read off the packed shots."""
        bitarray, rows, shots = self._packed
        return rows, shots, int(bitarray.num_bits)

    def set_clbits(self) -> tuple[np.ndarray, np.ndarray]:
        """The set clbits of every shot read off the packed bytes (:func:`packed_set_bits`;
        see :meth:`JobResult.set_clbits`), never unpacked to ``num_clbits`` per shot."""
        return packed_set_bits(self._bytes(), self._packed[0].num_bits)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_unpacked"] = None
        return state
