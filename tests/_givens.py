"""The unary engine's oracle: a circuit of Givens rotations as an explicit matrix product."""

from __future__ import annotations

import numpy as np


def dense(n, pairs, angles):
    """``O = R_G ... R_1`` from explicit rotation matrices (Supp. D eq. 8): ``R`` rotates the
    plane ``(i, j)`` of each pair by its angle, ``y_i -> cos y_i - sin y_j``."""
    O = np.eye(n)
    for (i, j), a in zip(pairs, angles, strict=True):
        R = np.eye(n)
        R[i, i], R[i, j], R[j, i], R[j, j] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a)
        O = R @ O
    return O
