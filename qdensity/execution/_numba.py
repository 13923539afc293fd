"""numba, where it runs: the compiled kernels of the unary and statevector engines.

numba is a core dependency; ``QDENSITY_NUMBA=0`` (or ``false``, ``no``, ``off``) in the
environment switches it off before the first import, and the engines then run their numpy
paths, which compute the same numbers (the tests run both).
"""

from __future__ import annotations

import os

__all__ = ["available", "threads", "numba"]

try:
    if os.environ.get("QDENSITY_NUMBA", "1").strip().lower() in ("0", "false", "no", "off"):
        raise ImportError("disabled by QDENSITY_NUMBA")
    import numba
except ImportError:  # pragma: no cover - exercised with QDENSITY_NUMBA=0
    numba = None  # type: ignore[assignment]  # optional: callers check available() first


def available() -> bool:
    """True when numba is installed and not disabled by ``QDENSITY_NUMBA=0``."""
    return numba is not None


def threads() -> int:
    """numba's thread count (1 without numba): rows a parallel region can use at once."""
    return numba.get_num_threads() if numba is not None else 1
