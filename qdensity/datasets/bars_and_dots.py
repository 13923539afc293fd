"""Noisy bars and dots (paper Methods, "Equivariant density QNN"; Bowles et al.): a
translation-invariant binary task on a ring of ``d`` sites, the data of the equivariant models."""

from __future__ import annotations

import numpy as np

from qdensity.validation import (
    MAX_DENSE_ENTRIES,
    MAX_ROWS,
    Interval,
    Qubits,
    Seed,
    SeedLike,
    as_rng,
    validates,
)

__all__ = ["bars_and_dots"]


@validates(
    num_samples=Interval(int, 1, MAX_ROWS), num_qubits=Qubits(4), noise_std=Interval(float, 0),
    seed=Seed(),
)
def bars_and_dots(
    num_samples: int,
    num_qubits: int,
    noise_std: float = 0.0,
    seed: SeedLike = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Noisy bars-and-dots data set (Methods "Equivariant density QNN"; Bowles et al.).

    Each sample is a bar (label ``+1``) or a dot (label ``-1``) with probability 1/2. Write
    ``L = floor(d / 2)``. A clean *bar* is ``+1`` everywhere except a run of ``L`` consecutive
    ``-1`` entries; a clean *dot* is ``+1`` everywhere except ``-1`` at ``L`` positions two apart
    (so alternating ``-1, +1, -1, ...`` for even ``d``). The pattern starts at a uniformly random
    site and wraps around the ring, so the task is translation invariant; then independent
    Gaussian noise ``N(0, noise_std^2)`` is added to every entry.

    Parameters
    ----------
    num_samples : int
        ``N >= 1``.
    num_qubits : int
        Dimension ``d >= 4`` (for ``d < 4`` bars and dots coincide).
    noise_std : float
        Standard deviation ``σ >= 0`` of the noise (the paper uses ``σ = 1.8``).
    seed : int, numpy.random.Generator or None

    Returns
    -------
    X : numpy.ndarray, shape (N, d)
        Features, one row per sample (feed to
        :func:`qdensity.circuits.ansatze.angle_encoding`).
    y : numpy.ndarray, shape (N,)
        Labels in ``{+1, -1}`` (int).

    Examples
    --------
    >>> X, y = bars_and_dots(4, 6, seed=1)
    >>> X.shape, sorted(set(y.tolist())) <= [-1, 1]
    ((4, 6), True)
    """
    num, d = int(num_samples), int(num_qubits)
    if num * d > MAX_DENSE_ENTRIES:
        raise ValueError(f"num_samples * num_qubits = {num * d} entries exceed "
                         f"{MAX_DENSE_ENTRIES} (2 GiB of float64); draw fewer samples")
    sigma = float(noise_std)
    rng = as_rng(seed)
    length = d // 2
    is_bar = rng.random(num) < 0.5
    start = rng.integers(0, d, size=num)
    X = np.ones((num, d))
    step = np.where(is_bar, 1, 2)
    offsets = np.arange(length)
    cols = (start[:, None] + step[:, None] * offsets[None, :]) % d
    X[np.arange(num)[:, None], cols] = -1.0
    X += rng.normal(0.0, sigma, size=X.shape)
    y = np.where(is_bar, 1, -1)
    return X, y
