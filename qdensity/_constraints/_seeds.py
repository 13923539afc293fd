"""Seeds: the :class:`Seed` constraint and the checks that turn a seed into what a library needs.

Every stochastic function takes ``seed`` as an int ``>= 0``, a ``numpy.random.Generator`` or
None; :func:`check_seed` is the one place that is checked (so ``seed=-1`` anywhere is refused
naming the argument), :func:`as_rng`, :func:`seed_int` and :func:`seed_u32` turn it into a
Generator, an int for Aer and the transpiler, or scikit-learn's ``random_state``. Exported by
:mod:`qdensity.validation`.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from qdensity._constraints._core import Constraint
from qdensity._constraints._values import _ScalarMixin

__all__ = ["Seed", "SeedLike", "check_seed", "as_rng", "seed_int", "seed_u32"]

SeedLike = int | np.random.Generator | None


class Seed(_ScalarMixin, Constraint):
    """A seed: an int in ``[0, high]``, a ``numpy.random.Generator`` or None.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.validation import Seed
    >>> [Seed().is_satisfied_by(s) for s in (7, None, np.random.default_rng(0), -1, True)]
    [True, True, True, False, False]
    """

    def __init__(self, high: int = 2**63 - 1):
        self.high = high

    def type_ok(self, value) -> bool:
        if value is None or isinstance(value, np.random.Generator):
            return True
        return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))

    def is_satisfied_by(self, value) -> bool:
        if not self.type_ok(value):
            return False
        return not isinstance(value, numbers.Integral) or 0 <= int(value) <= self.high

    def __str__(self) -> str:
        return f"an int >= 0 and <= {self.high}, a numpy.random.Generator or None"

    def example(self) -> int:
        return 7

    def violations(self) -> list:
        return [-1, self.high + 1, 1.5, "7", math.nan, True, object(), [1]]


def check_seed(seed, name: str = "seed") -> SeedLike:
    """A seed as every stochastic function takes it: an int ``>= 0``, a Generator or None.

    The one place seeds are checked, so ``seed=-1`` anywhere is refused with a message that
    names the argument (numpy's own says only "expected non-negative integer").

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message.

    Returns
    -------
    int, numpy.random.Generator or None
        ``seed`` itself (a numpy integer becomes an int).

    Examples
    --------
    >>> check_seed(3), check_seed(None)
    (3, None)
    >>> check_seed(-1, "random_state")
    Traceback (most recent call last):
        ...
    ValueError: random_state must be an int >= 0, a numpy.random.Generator or None, got -1
    """
    if seed is None or isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"{name} must be an int >= 0, a numpy.random.Generator or None, got "
                        f"{type(seed).__name__} {seed!r}")
    if seed < 0:
        raise ValueError(f"{name} must be an int >= 0, a numpy.random.Generator or None, got "
                         f"{seed!r}")
    return int(seed)


def as_rng(seed: SeedLike, name: str = "seed") -> np.random.Generator:
    """A ``numpy.random.Generator`` from an int ``>= 0``, a Generator (returned as is) or None.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message (see :func:`check_seed`).

    Returns
    -------
    numpy.random.Generator

    Examples
    --------
    >>> as_rng(0).integers(10, size=3).tolist() == as_rng(0).integers(10, size=3).tolist()
    True
    """
    seed = check_seed(seed, name)
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


def seed_int(seed: SeedLike, name: str = "seed") -> int | None:
    """An integer seed for libraries that need one (Aer's ``seed_simulator``, transpiler).

    Draws from the generator when given one, so a Generator still yields reproducible runs.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message (see :func:`check_seed`).

    Returns
    -------
    int or None

    Examples
    --------
    >>> seed_int(5), seed_int(None), 0 <= seed_int(as_rng(0)) < 2**31
    (5, None, True)
    """
    seed = check_seed(seed, name)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**31 - 1))
    return seed


def seed_u32(seed: SeedLike, name: str = "seed") -> int | None:
    """:func:`seed_int` within ``[0, 2**32 - 1]``, scikit-learn's ``random_state`` range (a
    larger int is refused naming ``name``, not passed on to fail inside scikit-learn).

    Examples
    --------
    >>> seed_u32(2**32)
    Traceback (most recent call last):
        ...
    ValueError: seed must be at most 2**32 - 1 = 4294967295 (scikit-learn's random_state ...
    """
    out = seed_int(seed, name)
    if out is not None and out > 2**32 - 1:
        raise ValueError(f"{name} must be at most 2**32 - 1 = {2**32 - 1} (scikit-learn's "
                         f"random_state range), got {out}")
    return out
