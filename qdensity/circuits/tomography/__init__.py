r"""l-infinity tomography of unary states with three circuits (Supp. F; Landman et al. Fig. 18).

An orthogonal QNN leaves its output ``y`` (real, unit norm) in the unary subspace:
``|y> = sum_j y_j |e_j>``, ``e_j`` the basis state with only qubit ``j`` set (statevector entry
``2**j``). Three measured circuits give an estimate ``y_hat`` with ``||y_hat - y||_inf <= delta``
(up to the unobservable global sign) from ``O(log(n) / delta^2)`` shots each
(Kerenidis-Prakash l-infinity tomography, specialised to unary states):

0. the circuit itself, measured in the computational basis: ``p_j = y_j^2`` gives the
   magnitudes ``|y_j| = sqrt(p_j)``;
1. the circuit followed by ``RBS(pi/4)`` on the "even" pairs ``(0, 1), (2, 3), ...``;
2. the circuit followed by ``RBS(pi/4)`` on the "odd" pairs ``(1, 2), (3, 4), ...``.

After ``RBS(pi/4)`` on ``(a, b)`` the unary amplitudes are ``(y_a - y_b)/sqrt(2)`` and
``(y_a + y_b)/sqrt(2)``, so ``p'_b - p'_a = 2 y_a y_b`` and::

    D_ab := sqrt(2 p'_b) - sqrt(2 p'_a) = |y_a + y_b| - |y_a - y_b|
          = 2 sign(y_a y_b) min(|y_a|, |y_b|),

which fixes the relative sign of ``y_a`` and ``y_b`` exactly when ``D_ab`` is significantly
non-zero. Signs are propagated only along significant edges (never through an amplitude that
is zero within the error), starting from the largest amplitude, taken positive.

**Gaps.** When an amplitude between two non-negligible ones is (near) zero, e.g.
``y = (a, b, 0, c, d)``, the three circuits cannot tell ``(a, b, 0, c, d)`` from
``(a, b, 0, -c, -d)``: both give identical statistics. :func:`reconstruct` then reports the
separate sign ``components`` and an ``error_estimate`` that honestly covers either sign. To join
them, run :func:`bridge_circuit` with ``RBS(pi/4)`` on pairs across the gap (e.g. ``(1, 3)``;
:func:`bridge_pairs` suggests them) and pass its counts to ``reconstruct(..., extra=...)``.

Counts use Qiskit's keys: bitstrings with qubit 0 rightmost (``"0010"`` is ``e_1``), as from
``SamplerV2`` results (``result[i].data.meas.get_counts()``), or integers ``sum_j b_j 2^j``.

Modules: :mod:`.circuits` (the measured and bridge circuits), :mod:`.bounds`
(:func:`shots_for_error`, :data:`SIGN_FACTOR`), :mod:`.reconstruction` (counts,
:class:`TomographyResult`, :func:`reconstruct`, :func:`bridge_pairs`); ``_common`` holds the
helpers they share.
"""

from qdensity.circuits.tomography.bounds import SIGN_FACTOR, shots_for_error
from qdensity.circuits.tomography.circuits import bridge_circuit, tomography_circuits
from qdensity.circuits.tomography.reconstruction import (
    TomographyResult,
    bridge_pairs,
    reconstruct,
)

__all__ = [
    "TomographyResult",
    "tomography_circuits",
    "bridge_circuit",
    "bridge_pairs",
    "reconstruct",
    "shots_for_error",
    "SIGN_FACTOR",
]
