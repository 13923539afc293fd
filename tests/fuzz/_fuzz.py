"""Shared pieces of the fuzzers: the refusal check, bad-value strategies and the tally.

Every fuzzer sends random invalid input to a public entry point through :func:`refused`, which
requires a ``ValueError`` or ``TypeError`` (anything else, a crash or a ``MemoryError``, fails
the test) and counts the attempt under the entry point's name. With
``QDENSITY_FUZZ_COUNTS=path.json`` the tally is written there at the end of the session
(``benchmarks/fuzz_counts.py`` does this and prints the table).
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
from hypothesis import strategies as st

TALLY: Counter = Counter()

#: Non-finite floats.
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
#: Things that are not real numbers.
NOT_A_NUMBER = st.one_of(
    st.text(max_size=4), st.none(), st.complex_numbers(allow_nan=False, allow_infinity=False,
                                                       min_magnitude=1e-3),
    st.just(("a", 1.0)), st.just(object()),
)
#: Non-integers and non-positive integers.
BAD_SIZES = st.one_of(
    st.integers(-10**6, 0), st.floats(allow_nan=True), st.text(max_size=3), st.none(),
    st.booleans(),
)
#: Widths no builder or dense path may try to honour.
HUGE = st.integers(10**5, 10**12)


def refused(entry: str, fn, *args, **kwargs) -> Exception:
    """Call ``fn``; it must raise ``ValueError`` or ``TypeError``. Counted under ``entry``."""
    TALLY[entry] += 1
    try:
        fn(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        assert str(exc), f"{entry}: empty error message"
        return exc
    raise AssertionError(f"{entry} accepted bad input args={args!r} kwargs={kwargs!r}")


def accepted(entry: str) -> None:
    """Count a valid input tried (``entry`` + ``" (valid)"``)."""
    TALLY[f"{entry} (valid)"] += 1


def poison(arr: np.ndarray, data, values=NON_FINITE) -> np.ndarray:
    """A copy of ``arr`` with one entry (drawn by ``data``) replaced by a drawn bad value."""
    out = np.array(arr, dtype=float, copy=True)
    if out.size == 0:
        return out
    i = data.draw(st.integers(0, out.size - 1), label="index")
    out.flat[i] = data.draw(values, label="bad value")
    return out
