"""Whole-circuit calls of the compiled kernels (:mod:`._kernels`), in column-block threads.

:func:`forward_rows` and :func:`vjp_rows` are what :func:`qdensity.execution.unary.forward`
and :func:`~qdensity.execution.unary.vjp` run when numba is available: the angles' cosines
and sines computed once, then one compiled call per block of batch rows, each running the
whole circuit (no Python loop over gates or layers). A batch worth threads
(:func:`qdensity.execution._threads.blocks`: about ``MIN_WORK`` multiply-adds per thread) is
cut into contiguous row blocks run in the pool (the kernels release the GIL); with angles
shared by the batch, the block threads first compute the cosines and sines in slices
(:class:`_SharedTrig`: one hand-off to the threads per call). Each thread runs its rows in
calls of at most ``WIDTH`` columns. Once a large circuit has carried a few hundred columns, the
calls run its gates in the cache-tiled order of :mod:`._tiles` (the same numbers).
"""

from __future__ import annotations

import threading

import numpy as np

from qdensity.execution._threads import blocks, run_blocks, split
from qdensity.execution.unary import _kernels
from qdensity.execution.unary._tiles import tiled

__all__: list[str] = []

# multiply-adds per column and gate: 4 in the forward pass, 4 more in the reverse pass's
# rotations of the activations and 4 of the gradients (its dot products add 2)
_FORWARD_WORK, _VJP_WORK = 4, 14
# Gates up to which a single block with shared values computes its angles inside the kernel
# call (no numpy calls between the arguments and the kernel: a few us saved per call); larger
# circuits compute them once with numpy and the compiled sin / cos (the same numbers), as the
# threaded path must.
_SMALL = 2048
# Measured (round-robin circuits, batch 64, one core): building O and multiplying ran 1.2-1.5x
# slower than rotating the rows at n = 8-48 for 0.8-1.2x the flops, so composing is chosen
# only when its flops are below 1 / 1.5 of rotating's (a deep circuit, a batch much wider than
# n). With batch 64 the rows are rotated at every width. (Measured with a compiled loop for
# the product; BLAS's is faster, so the weight errs towards rotating.)
COMPOSE_WEIGHT = 1.5
# Batch columns per kernel call: a wider block (one thread's share of a wide batch) runs in
# calls of WIDTH columns, each with work rows of 512 bytes that the tiled gate order (._tiles)
# keeps in L1 (a row of 1000 columns would be 8 KB: a few rows fill L1)
WIDTH = 64


def _runs(lo: int, hi: int) -> list[tuple[int, int]]:
    """A thread's columns ``[lo, hi)`` in kernel calls of ``WIDTH`` columns (the last one
    shorter)."""
    return [(a, min(a + WIDTH, hi)) for a in range(lo, hi, WIDTH)]


def _width(ranges: list[tuple[int, int]]) -> int:
    """Columns of the widest kernel call over ``ranges`` (the tiles are sized for it)."""
    return min(WIDTH, max(hi - lo for lo, hi in ranges))


class _SharedTrig:
    """The cosines and sines of angles shared by the columns, computed in slices by the
    threads that need them: each thread takes its own slice first, then any slice no thread
    has started, and then waits for those under way. The threads' shares of the rotations
    start as soon as every slice is done (one hand-off to the threads per call), and no thread
    ever waits for a slice that no running thread is computing (a pool thread that starts
    late, or never, holds nobody up). The numbers are those of one pass."""

    def __init__(self, compiled, values: np.ndarray, parts: int) -> None:
        G = compiled.num_gates
        self.cos, self.sin = np.empty(G), np.empty(G)
        self._compiled, self._values = compiled, values
        self._slices = split(G, parts)
        self._claimed = [False] * parts
        self._done = [threading.Event() for _ in range(parts)]
        self._lock = threading.Lock()

    def ready(self, first: int) -> tuple[np.ndarray, np.ndarray, bool]:
        """Every slice done (slice ``first`` tried first); the trig tuple of the kernels."""
        for k in [first, *range(len(self._slices))]:
            with self._lock:
                if self._claimed[k]:
                    continue
                self._claimed[k] = True
            lo, hi = self._slices[k]
            try:
                _kernels.trig_slice(self._compiled, self._values, lo, hi, self.cos, self.sin)
            finally:  # an error is raised in the caller (run_blocks); nobody waits forever
                self._done[k].set()
        for done in self._done:
            done.wait()
        return self.cos, self.sin, False


def _trig_for(compiled, values: np.ndarray, ranges: list[tuple[int, int]]):
    """``trig(lo, hi)``: the trig tuple for the block ``[lo, hi)`` of ``ranges`` (per-row
    values: computed once, before the threads)."""
    if values.ndim == 2 or len(ranges) == 1:
        trig = _kernels.trig_of(compiled, values)
        return lambda lo, hi: trig
    shared = _SharedTrig(compiled, values, len(ranges))
    slot = {r: k for k, r in enumerate(ranges)}
    return lambda lo, hi: shared.ready(slot[(lo, hi)])


def composed_cheaper(n: int, G: int, B: int) -> bool:
    """Whether building ``O`` (``6 G n`` flops) and multiplying (``2 n^2 B``) beats rotating
    the ``B`` rows (``6 G B``), the composed route's flops weighted ``COMPOSE_WEIGHT``."""
    return COMPOSE_WEIGHT * (6 * G * n + 2 * n * n * B) < 6 * G * B


def forward_rows(X: np.ndarray, compiled, values: np.ndarray) -> np.ndarray:
    """``Y[b] = O(values_b) @ X[b]`` for rows ``X`` (B, n), C-contiguous float64.

    Parameters
    ----------
    X : numpy.ndarray, shape (B, n)
    compiled : UnaryCircuit
    values : numpy.ndarray, shape (P,) shared by the rows, or (B, P) one row per input row

    Returns
    -------
    numpy.ndarray, shape (B, n)
    """
    (B, n), G = X.shape, compiled.num_gates
    out = np.empty_like(X)
    ranges = blocks(B, _FORWARD_WORK * G)
    if values.ndim == 1 and composed_cheaper(n, G, B):  # O once (one thread), then BLAS
        O = _kernels.givens(np.eye(n), compiled, compiled.angles(values))
        return np.matmul(X, O.T, out=out)
    if len(ranges) == 1 and values.ndim == 1 and G <= _SMALL and B <= WIDTH:
        _kernels.forward_values(X, values, compiled, out)
        return out
    compiled = tiled(compiled, 8 * _width(ranges), B)
    trig_for = _trig_for(compiled, values, ranges)

    def block(lo: int, hi: int) -> None:
        trig = trig_for(lo, hi)
        for a, b in _runs(lo, hi):
            _kernels.forward_block(X, a, b, compiled, trig, out)

    run_blocks(block, ranges)
    return out


def vjp_rows(X: np.ndarray, GY: np.ndarray, from_outputs: bool, compiled, values: np.ndarray,
             per_example: bool) -> tuple[np.ndarray, np.ndarray]:
    """Parameter gradient and ``dL/dX`` of ``L`` with ``dL/dY = GY`` (both (B, n) rows).

    Parameters
    ----------
    X : numpy.ndarray, shape (B, n)
        Inputs, or the forward pass's outputs when ``from_outputs`` (then not run again).
    GY : numpy.ndarray, shape (B, n)
    from_outputs : bool
    compiled : UnaryCircuit
    values : numpy.ndarray, shape (P,) or (B, P)
    per_example : bool

    Returns
    -------
    grad : numpy.ndarray, shape (P, B) when ``per_example`` else (P,)
    grad_X : numpy.ndarray, shape (B, n)
    """
    B, P, G = X.shape[0], compiled.num_parameters, compiled.num_gates
    ranges = blocks(B, _VJP_WORK * G)
    grad_X = np.empty_like(X)
    if len(ranges) == 1 and values.ndim == 1 and G <= _SMALL and not per_example and B <= WIDTH:
        grad1 = np.zeros((P, 1))
        _kernels.vjp_values(X, GY, from_outputs, values, compiled, grad1, grad_X)
        return grad1[:, 0], grad_X
    compiled = tiled(compiled, 16 * _width(ranges), B)
    trig_for = _trig_for(compiled, values, ranges)
    if per_example:
        grad = np.zeros((P, B))
        parts = [grad] * len(ranges)
    else:
        grad = np.zeros((len(ranges), P, 1))
        parts = list(grad)
    slot = {r: k for k, r in enumerate(ranges)}

    def block(lo: int, hi: int) -> None:
        trig = trig_for(lo, hi)
        for a, b in _runs(lo, hi):  # the partial sums of a thread's runs add up in its part
            _kernels.vjp_block(X, GY, from_outputs, a, b, compiled, trig, per_example,
                               parts[slot[(lo, hi)]], grad_X)

    run_blocks(block, ranges)
    if per_example:
        return grad, grad_X
    return (grad[0, :, 0] if len(ranges) == 1 else grad.sum(axis=0)[:, 0]), grad_X
