"""Seeds of the statistical tests: each test's own default, or ``QDENSITY_STAT_SEED`` when set
(``benchmarks/fuzz_statistics.py`` runs every statistical test over 50 seeds with it); and
variance bounds that several statistical tests share."""

from __future__ import annotations

import os

import numpy as np


def stat_seed(default: int) -> int:
    """``default``, or ``QDENSITY_STAT_SEED`` when set (read at call time)."""
    return int(os.environ.get("QDENSITY_STAT_SEED", default))


#: ``sum_t c_t^2`` of the four-term RBS rule (Supp. E eq. 23): coefficients 1, -1 and
#: -+(sqrt(2) - 1) / 2.
FOUR_TERM_SQUARES = 2.0 + 2.0 * ((2.0**0.5 - 1.0) / 2.0) ** 2


def unary_input_vjp_sd(alpha, loader_jacobian, upstream, shots, gate_jacobian=None):
    """An upper bound on the standard deviation of a sampled ``dL/dx`` of a unary-probability
    density QNN whose data enter only through the unary loader (RBS angles ``phi(x)``).

    The estimate is ``sum_k alpha_k sum_c J_ci sum_t c_t u . p_hat(k, c, t)`` (the four-term
    rule on loader angle ``c``, ``J = d phi / d x``) plus ``sum_k G_ki u . p_hat(k)`` (the
    forward frequencies times ``G = d alpha / d x`` of a data-dependent mixture), ``u`` the
    upstream ``dL/dp``. Each circuit row is independent; within one, ``u . p_hat`` is the mean
    over shots of ``u`` at the observed outcome (0 off the unary outcomes), a variable in
    ``[min(u, 0), max(u, 0)]``, so its variance is at most ``range^2 / (4 shots)``
    (Popoviciu). Summing the independent rows' variances:
    ``Var <= range^2 / (4 shots) (sum_k alpha_k^2 sum_c J_ci^2 FOUR_TERM_SQUARES
    + sum_k G_ki^2)``.

    Parameters
    ----------
    alpha : array, shape (B, K)
    loader_jacobian : array, shape (B, d - 1, d)
    upstream : array, shape (B, n)
    shots : int
    gate_jacobian : array, shape (B, K, d), optional

    Returns
    -------
    numpy.ndarray, shape (B, d)
    """
    alpha, J, u = (np.asarray(a, dtype=float) for a in (alpha, loader_jacobian, upstream))
    spread = np.maximum(u.max(axis=1), 0.0) - np.minimum(u.min(axis=1), 0.0)  # (B,)
    weight = (alpha**2).sum(axis=1)[:, None] * (J**2).sum(axis=1) * FOUR_TERM_SQUARES
    if gate_jacobian is not None:
        weight = weight + (np.asarray(gate_jacobian, dtype=float) ** 2).sum(axis=1)
    return np.sqrt(spread[:, None] ** 2 / (4.0 * shots) * weight)
