"""The Hastings-Campbell mixing lemma and its supervised-learning form (paper Lemma 1, Supp. B.2).

If every sub-unitary is ``eps_1``-close to a target ``V`` (``||U_k - V|| <= eps_1``) and their
linear combination is ``eps_2``-close (``||sum_k alpha_k U_k - V|| <= eps_2``), the randomised
(density) channel ``Lambda(rho) = sum_k alpha_k U_k rho U_k^dagger`` is ``eps_1^2 + 2 eps_2``-close
to ``V . V^dagger`` in diamond norm (eq. mixing_lemma_result). In supervised learning, with
``delta_1`` the worst sub-unitary's and ``delta_2`` the LCU model's mean prediction error, the
density model's error is at most ``delta_1^2 / (4 ||O||) + 2 delta_2`` (Lemma 1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from qdensity.validation import check_distribution, check_nonnegative_float

__all__ = ["mixing_lemma_terms", "supervised_mixing_bound", "trace_distance"]


def _matrix(u, name: str) -> np.ndarray:
    arr = np.asarray(getattr(u, "data", u), dtype=complex)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
        raise ValueError(f"{name} must be a square matrix, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def mixing_lemma_terms(unitaries: Sequence, alpha, target) -> dict[str, float]:
    """The two conditions of the mixing lemma and the bound they give.

    Parameters
    ----------
    unitaries : sequence of array_like or Operator, length K
        The sub-unitaries ``U_k`` (square matrices of one size; an orthogonal matrix of the unary
        engine is fine: the lemma holds on any invariant subspace).
    alpha : array_like, shape (K,)
        A distribution.
    target : array_like or Operator
        The target unitary ``V``, the size of the ``U_k``.

    Returns
    -------
    dict
        ``eps_1 = max_k ||U_k - V||``, ``eps_2 = ||sum_k alpha_k U_k - V||`` (operator norms),
        ``bound = eps_1^2 + 2 eps_2`` on ``||Lambda - V . V^dagger||_diamond``.

    Examples
    --------
    >>> import numpy as np
    >>> e = 0.1
    >>> U = [np.diag(np.exp([1j * e, -1j * e])), np.diag(np.exp([-1j * e, 1j * e]))]
    >>> t = mixing_lemma_terms(U, [0.5, 0.5], np.eye(2))
    >>> round(t["eps_2"], 6), round(t["bound"], 6)   # 1 - cos e, 4 (1 - cos e)
    (0.004996, 0.019983)
    """
    mats = [_matrix(u, f"unitaries[{k}]") for k, u in enumerate(unitaries)]
    if not mats:
        raise ValueError("unitaries must hold at least one matrix")
    a = check_distribution(alpha, "alpha")
    if a.size != len(mats):
        raise ValueError(f"alpha has {a.size} entries for {len(mats)} unitaries")
    V = _matrix(target, "target")
    for k, m in enumerate(mats):
        if m.shape != V.shape:
            raise ValueError(f"unitaries[{k}] has shape {m.shape}, target {V.shape}")
    eps1 = max(float(np.linalg.norm(m - V, 2)) for m in mats)
    lcu = sum(ak * m for ak, m in zip(a, mats, strict=True))
    eps2 = float(np.linalg.norm(lcu - V, 2))
    return {"eps_1": eps1, "eps_2": eps2, "bound": eps1**2 + 2 * eps2}


def supervised_mixing_bound(delta_1: float, delta_2: float, observable_norm: float = 1.0) -> float:
    """Lemma 1: the density model's mean prediction error bound ``delta_1^2/(4||O||) + 2 delta_2``.

    Parameters
    ----------
    delta_1 : float
        Largest mean absolute error of a single sub-unitary model, ``>= 0``.
    delta_2 : float
        Mean absolute error of the LCU model, ``>= 0``.
    observable_norm : float
        ``||O||_inf > 0`` of the read-out observable (1 for a Pauli ``Z``).

    Returns
    -------
    float

    Examples
    --------
    >>> supervised_mixing_bound(0.2, 0.04)
    0.09
    """
    d1 = check_nonnegative_float(delta_1, "delta_1")
    d2 = check_nonnegative_float(delta_2, "delta_2")
    norm = check_nonnegative_float(observable_norm, "observable_norm")
    if norm == 0.0:
        raise ValueError("observable_norm must be positive")
    return round(d1**2 / (4 * norm) + 2 * d2, 15)


def trace_distance(rho, sigma) -> float:
    """Trace norm ``||rho - sigma||_1`` of two density matrices (what the lemma bounds).

    Parameters
    ----------
    rho, sigma : array_like, shape (d, d)
        Hermitian matrices (density matrices).

    Returns
    -------
    float
        The sum of the absolute eigenvalues of ``rho - sigma`` (``<= 2`` for states).

    Examples
    --------
    >>> trace_distance(np.diag([1.0, 0.0]), np.diag([0.0, 1.0]))
    2.0
    """
    a, b = _matrix(rho, "rho"), _matrix(sigma, "sigma")
    if a.shape != b.shape:
        raise ValueError(f"rho has shape {a.shape}, sigma {b.shape}")
    diff = a - b
    if not np.allclose(diff, diff.conj().T, atol=1e-10):
        raise ValueError("rho and sigma must be Hermitian")
    return float(np.abs(np.linalg.eigvalsh(diff)).sum())
