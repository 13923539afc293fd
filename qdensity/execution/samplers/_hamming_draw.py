"""Drawing one PUB's shots from its exact probabilities, now or when they are read.

:class:`Draw` holds what drawing needs and nothing of the circuit: the compiled program (the
unary engine's Givens layers, or the subspace's index tables), the PUB's parameter rows, the
outcome table and the readout channel's flip probabilities. :meth:`Draw.packed` draws every
row's shots (one multinomial per row, shuffled into shot order), writes them as packed clbits
and flips them with the readout channel.

:class:`DeferredSamples` is a drawing kept for later: it holds a :class:`Draw` and the seed
of the PUB's own random stream, and draws when read, the same shots on every read. A density
gradient at device widths holds hundreds of jobs until its post-processing reads them one
after another: drawn at once, ``n = 256`` (510 jobs of 16 rows x 1,000 shots) keeps 0.26 GB
of packed shots; drawn on read, one job's at a time.
"""

from __future__ import annotations

import numpy as np
from qiskit.primitives import BitArray

from qdensity.execution.samplers._hamming_bits import (
    clbits_of_qubits,
    flip_readout,
    pack_outcomes,
)
from qdensity.execution.samplers._hamming_program import identity_clbits

__all__ = ["Draw", "DeferredSamples"]

#: Amplitudes (rows x dimension) computed at once; rows go in chunks of this size.
CHUNK_AMPLITUDES = 2**23


class Draw:
    """What drawing one PUB's shots needs (see the module).

    Parameters
    ----------
    compiled : hamming._Compiled
        The template's program (only its program and outcome table are kept).
    values : numpy.ndarray, shape (rows, P), or a function giving it
        Parameter rows in the template's parameter order (a function is called on each
        draw: a deferred drawing then holds the PUB's own rows, not a reordered copy).
    rows : int
        ``values``'s rows.
    shots : int
        Shots per row.
    readout : ReadoutChannel or None
    """

    __slots__ = ("probabilities", "outcome_qubits", "table", "cols", "p01", "p10", "values",
                 "rows", "shots", "num_clbits", "flip")

    def __init__(self, compiled, values, rows: int, shots: int, readout) -> None:
        template = compiled.template
        self.probabilities = compiled.probabilities_function()
        self.values = values
        self.rows, self.shots = int(rows), int(shots)
        self.num_clbits = len(template.measured)
        if getattr(compiled, "identity", False):  # a program's: shared per width, read-only
            self.cols, self.table = identity_clbits(template.num_qubits)
        else:
            self.cols = np.array([c for c, q in enumerate(template.measured) if q is not None],
                                 dtype=np.int64)
            self.table = clbits_of_qubits(template.measured, template.num_qubits)
        self.outcome_qubits = compiled.outcome_qubits() if self.cols.size else None
        # clbits read through a final bit flip (a relabelling): XORed into every shot
        self.flip = None
        if template.flipped:
            self.flip = np.zeros(self.num_bytes, dtype=np.uint8)
            for c in template.flipped:
                self.flip[c >> 3] |= np.uint8(1 << (c & 7))
        self.p01 = self.p10 = None
        if readout is not None and self.cols.size:
            self.p01, self.p10 = readout.for_qubits(
                np.array([template.measured[c] for c in self.cols], dtype=np.int64))

    @property
    def num_bytes(self) -> int:
        """Bytes per shot: ``ceil(num_clbits / 8)``."""
        return (self.num_clbits + 7) // 8

    def packed(self, rng: np.random.Generator) -> np.ndarray:
        """Every row's shots, drawn: uint8 ``(rows * shots, num_bytes)``, clbit ``c`` in bit
        ``c % 8`` of byte ``c // 8`` (little-endian; a ``BitArray`` holds them reversed)."""
        rows, shots, nbytes = self.rows, self.shots, self.num_bytes
        packed = np.zeros((rows * shots, nbytes), dtype=np.uint8)
        if self.outcome_qubits is None:
            return packed
        dim = self.outcome_qubits.shape[0]
        values = self.values() if callable(self.values) else self.values
        step = max(1, CHUNK_AMPLITUDES // max(dim, shots * nbytes))
        for start in range(0, rows, step):
            probs = np.clip(self.probabilities(values[start:start + step]), 0.0, None)
            probs /= probs.sum(axis=1, keepdims=True)
            counts = rng.multinomial(shots, probs)  # one multinomial per row
            draws = np.repeat(np.tile(np.arange(dim), counts.shape[0]), counts.ravel())
            draws = rng.permuted(draws.reshape(counts.shape[0], shots), axis=1)
            chunk = pack_outcomes(self.outcome_qubits, draws.ravel(), self.table,
                                  self.num_clbits)
            if self.flip is not None:  # the measured value is the flipped one
                chunk ^= self.flip
            if self.p01 is not None and self.p10 is not None:  # then read out with errors
                flip_readout(chunk, self.cols, self.p01, self.p10, rng)
            packed[start * shots:start * shots + chunk.shape[0]] = chunk
        return packed


class DeferredSamples:
    """One PUB's shots from :meth:`HammingWeightSampler.defer`, drawn when read.

    Every read draws the PUB's shots again from the same seed (a ``SeedSequence``), so every
    read gives the same shots; between reads nothing but the parameter rows and the compiled
    program is held.
    The shots are those :meth:`HammingWeightSampler.run` draws (the same code, from the
    PUB's own stream), over every clbit of the circuit in clbit order.

    Attributes
    ----------
    shape : tuple of int
        The PUB's parameter-array shape.
    num_shots : int
        Shots per parameter row.
    num_bits : int
        The circuit's clbits.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qdensity.execution.samplers import HammingWeightSampler
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.x(0)
    >>> qc.measure_all()
    >>> sampler = HammingWeightSampler(seed=1)
    >>> deferred, = sampler.defer([qc], shots=5)
    >>> deferred
    DeferredSamples(shape=(), num_shots=5, num_bits=2)
    >>> deferred.packed().shape  # 5 shots of one byte
    (5, 1)
    >>> deferred.bitarray().get_counts()
    {'01': 5}
    >>> run = sampler.run([qc], shots=5).result()[0].data.meas
    >>> bool((run.array == deferred.bitarray().array).all())  # run's shots
    True
    """

    __slots__ = ("_draw", "_seed", "shape", "num_shots", "num_bits")

    def __init__(self, draw: Draw, seed: np.random.SeedSequence, shape: tuple) -> None:
        self._draw, self._seed = draw, seed
        self.shape = tuple(shape)
        self.num_shots, self.num_bits = draw.shots, draw.num_clbits

    def packed(self) -> np.ndarray:
        """The shots as ``BitArray`` bytes: uint8 ``(rows * num_shots, ceil(num_bits / 8))``,
        big-endian (the last byte holds clbits 0..7), rows in C order of :attr:`shape`."""
        return self._draw.packed(np.random.default_rng(self._seed))[:, ::-1]

    def bitarray(self) -> BitArray:
        """The shots as one ``BitArray`` of every clbit, shape :attr:`shape`."""
        arr = self.packed().reshape(self.shape + (self.num_shots, -1))
        return BitArray(np.ascontiguousarray(arr), self.num_bits)

    def __repr__(self) -> str:
        return (f"DeferredSamples(shape={self.shape}, num_shots={self.num_shots}, "
                f"num_bits={self.num_bits})")
