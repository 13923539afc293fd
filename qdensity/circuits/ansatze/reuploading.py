"""Single-qubit data re-uploading model and the Chebyshev regression task (paper Fig. 6).

Methods "Data reuploading" (eq. 10-11) and Supp. G.3: layer ``l`` applies the data encoding
``V(x)`` and then the trainable ``U_l = R_z(θ^1_l) R_y(θ^2_l) R_z(θ^3_l)``, so the state is
``U_L V(x) ... U_1 V(x) |0>``. The encoding is the Hamiltonian encoding
``V(x) = R_x(x) = exp(-i x X / 2)`` by default (``R_y`` on request); each upload adds the
frequencies ``±1`` to the model's Fourier spectrum, so ``L`` layers give a partial Fourier series
of degree ``L`` in ``x``.
"""

from __future__ import annotations

import numpy as np
from qiskit.circuit import ParameterVector, QuantumCircuit

from qdensity.validation import SeedLike, as_rng, check_nonnegative_float, check_positive_int

__all__ = ["reuploading", "chebyshev_dataset", "ENCODINGS"]

#: Encoding gates a re-uploading layer may use.
ENCODINGS = ("rx", "ry")


def reuploading(
    layers: int,
    *,
    encoding: str = "rx",
    parameter_prefix: str = "θ",
    data_prefix: str = "x",
    name: str | None = None,
) -> QuantumCircuit:
    """Single-qubit data re-uploading circuit with ``layers`` uploads (Methods eq. 10-11).

    Layer ``l = 0 .. L - 1`` appends ``R_enc(x)`` and then ``rz(θ[3l + 2])``, ``ry(θ[3l + 1])``,
    ``rz(θ[3l])`` -- in matrix form ``U_l = R_z(θ[3l]) R_y(θ[3l + 1]) R_z(θ[3l + 2])``, the
    paper's ``R_z(θ^1_l) R_y(θ^2_l) R_z(θ^3_l)``. The whole circuit is
    ``U_{L-1} R_enc(x) ... U_0 R_enc(x)``.

    Parameter count: ``3 L`` trainable parameters plus the single data parameter ``x[0]``.
    ``circuit.parameters`` is sorted by name, so with the default prefixes it reads
    ``[x[0], θ[0], ..., θ[3L - 1]]``; split data from trainable parameters by vector name.

    Parameters
    ----------
    layers : int
        Number of uploads ``L >= 1``.
    encoding : {"rx", "ry"}
        Encoding gate ``R_x(x)`` (default) or ``R_y(x)``.
    parameter_prefix : str
        Name of the trainable ``ParameterVector`` (length ``3 L``).
    data_prefix : str
        Name of the data ``ParameterVector`` (length 1).
    name : str, optional
        Circuit name; defaults to ``"reuploading_{L}"``.

    Returns
    -------
    QuantumCircuit
        One qubit; ``L`` encoding gates and ``3 L`` trainable rotations.

    Raises
    ------
    ValueError
        For ``layers < 1`` or an unknown ``encoding``.

    Examples
    --------
    >>> qc = reuploading(2)
    >>> qc.num_parameters, [inst.operation.name for inst in qc.data][:4]
    (7, ['rx', 'rz', 'ry', 'rz'])
    """
    num_layers = check_positive_int(layers, "layers", minimum=1)
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {ENCODINGS}, got {encoding!r}")
    if parameter_prefix == data_prefix:
        raise ValueError(
            f"parameter_prefix and data_prefix must differ, both are {parameter_prefix!r}"
        )
    theta = ParameterVector(parameter_prefix, 3 * num_layers)
    x = ParameterVector(data_prefix, 1)
    qc = QuantumCircuit(1, name=name or f"reuploading_{num_layers}")
    for layer in range(num_layers):
        getattr(qc, encoding)(x[0], 0)
        qc.rz(theta[3 * layer + 2], 0)
        qc.ry(theta[3 * layer + 1], 0)
        qc.rz(theta[3 * layer], 0)
    return qc


def chebyshev_dataset(
    num_samples: int,
    degree: int = 4,
    noise_std: float = 0.5,
    seed: SeedLike = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Noisy samples of a Chebyshev polynomial ``h(x) = T_degree(x)`` (Methods, eq. 12).

    ``x`` is drawn uniformly from ``[-1, 1]``; the target is ``T_degree(x) + ε`` with
    ``ε ~ N(0, noise_std^2)`` (the paper uses ``T_4`` and variance 0.25, i.e. ``noise_std =
    0.5``, on the training data; ``noise_std = 0`` gives clean targets for a test set).
    ``T_0 = 1``, ``T_1 = x``, ``T_{k+1} = 2 x T_k - T_{k-1}``.

    Parameters
    ----------
    num_samples : int
        ``N >= 1``.
    degree : int
        Polynomial degree ``>= 0``.
    noise_std : float
        Noise standard deviation ``>= 0``.
    seed : int, numpy.random.Generator or None

    Returns
    -------
    X : numpy.ndarray, shape (N, 1)
        Inputs (one column, the re-uploading circuit's ``x[0]``).
    y : numpy.ndarray, shape (N,)
        Noisy targets.

    Examples
    --------
    >>> X, y = chebyshev_dataset(5, degree=2, noise_std=0.0, seed=0)
    >>> bool(np.allclose(y, 2 * X[:, 0] ** 2 - 1))
    True
    """
    num = check_positive_int(num_samples, "num_samples", minimum=1)
    deg = check_positive_int(degree, "degree", minimum=0)
    sigma = check_nonnegative_float(noise_std, "noise_std")
    rng = as_rng(seed)
    x = rng.uniform(-1.0, 1.0, size=num)
    prev, cur = np.ones_like(x), x.copy()
    if deg == 0:
        cur = prev
    for _ in range(deg - 1):
        prev, cur = cur, 2 * x * cur - prev
    y = cur + rng.normal(0.0, sigma, size=num)
    return x[:, None], y
