"""Shots for a target l-infinity error of unary tomography (Supp. F, Kerenidis-Prakash).

:func:`shots_for_error` (with its derivation) and :data:`SIGN_FACTOR`, the ratio
``delta / t`` of the l-infinity error to the square-root concentration radius.
"""

from __future__ import annotations

import math

from qdensity.validation import MAX_SHOTS, Interval, Qubits, refuse, validates

__all__ = ["shots_for_error", "SIGN_FACTOR"]

#: ``delta / t``: the l-infinity error ``delta`` guaranteed when every measured
#: ``sqrt``-probability is within ``t`` (see :func:`shots_for_error`), ``1 + 4 sqrt(2)``.
SIGN_FACTOR = 1.0 + 4.0 * math.sqrt(2.0)


@validates(
    delta=Interval(float, 0, None, closed='neither'), num_qubits=Qubits(2),
    p_fail=Interval(float, 0, 1, closed='neither'),
)
def shots_for_error(delta: float, num_qubits: int, p_fail: float = 0.01) -> int:
    r"""Shots per tomography circuit for l-infinity error ``<= delta`` w.p. ``>= 1 - p_fail``.

    Returns ``N = ceil((1 + 4 sqrt 2)^2 ln(6 n / p_fail) / delta^2)``
    (about ``44.3 ln(6n/p_fail) / delta^2``; Supp. F, Kerenidis-Prakash ``O(log(n)/delta^2)``).

    Parameters
    ----------
    delta : float
        Target l-infinity error, ``> 0``.
    num_qubits : int
        ``n >= 2``.
    p_fail : float
        Allowed failure probability, in ``(0, 1)``.

    Returns
    -------
    int
        Shots for each of the three circuits.

    Notes
    -----
    **Derivation.**
    *Square-root concentration.* For ``N`` shots and an outcome of probability ``p`` with
    frequency ``p_hat``, the Chernoff bound ``P(p_hat >= q) <= exp(-N KL(q||p))`` (``q > p``,
    similarly for ``q < p``) and ``KL(q||p) >= -2 ln(1 - H^2) >= 2 H^2 >= (sqrt q - sqrt p)^2``
    (``H`` the Hellinger distance of the Bernoulli laws) give::

        P(|sqrt(p_hat) - sqrt(p)| >= t) <= 2 exp(-N t^2)        for every p.

    A union bound over the ``n`` unary outcomes of each of the 3 circuits (``3n`` events) with
    ``t = sqrt(ln(6n / p_fail) / N)`` makes all ``3n`` estimates good at once with probability
    ``>= 1 - p_fail`` (the *good event*). On it:

    * magnitudes: ``| |y_hat_j| - |y_j| | <= t``;
    * sign tests: ``D_hat = sqrt(2 q_hat_b) - sqrt(2 q_hat_a)`` is within ``2 sqrt(2) t`` of
      ``D = 2 sign(y_a y_b) min(|y_a|, |y_b|)``. An edge is used only if
      ``|D_hat| > 2 sqrt(2) t``; then its sign is right. An unused edge has
      ``min(|y_a|, |y_b|) <= 2 sqrt(2) t =: kappa``.

    Take ``delta = (1 + 4 sqrt 2) t``, i.e. ``kappa = (delta - t) / 2``. If the indices with
    ``|y_j| > kappa`` form one contiguous run (no gap, see the package notes), neighbours in it
    are joined by used edges, so their relative signs are all right and, with the global sign
    that matches them, their error is ``<= t``. Every other index has ``|y_j| <= kappa``,
    so even with the wrong sign its error is ``<= |y_hat_j| + |y_j| <= 2 kappa + t = delta``.
    Post-selection replaces ``N`` by the kept shots (the bound holds conditionally on them).

    Examples
    --------
    >>> shots_for_error(0.1, 8, 0.01)
    37562
    """
    delta, n, p_fail = float(delta), int(num_qubits), float(p_fail)
    # in logarithms: delta**2 underflows to 0 below 1e-162 and the quotient overflows
    log_shots = 2 * math.log(SIGN_FACTOR) + math.log(math.log(6.0 * n / p_fail)) - 2 * math.log(
        delta)
    if log_shots > math.log(MAX_SHOTS):
        smallest = SIGN_FACTOR * math.sqrt(math.log(6.0 * n / p_fail) / MAX_SHOTS)
        raise refuse("shots_for_error", "delta", delta, f">= {smallest:.3g} for n = {n} and "
                     f"p_fail = {p_fail:g}", f"a smaller delta needs more than {MAX_SHOTS} "
                     "shots per circuit")
    if log_shots < 0:  # fewer than one shot: one (delta**2 would overflow above 1e154)
        return 1
    return math.ceil(SIGN_FACTOR**2 * math.log(6.0 * n / p_fail) / delta**2)
