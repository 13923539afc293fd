"""numba, where it runs: the compiled kernels of the unary and statevector engines.

numba is a core dependency; ``QDENSITY_NUMBA=0`` (or ``false``, ``no``, ``off``) in the
environment switches it off before the first import, and the engines then run their numpy
paths, which compute the same numbers (the tests run both).

Compiled kernels are cached on disk (:func:`jit`) so that a new process does not compile them
again. numba writes the cache to ``NUMBA_CACHE_DIR`` when that is set, else next to the
installed module (its ``__pycache__``) when that folder is writable, else to the user's cache
folder (``~/.cache/numba`` on Linux). A read-only install therefore caches in the user's folder;
where no folder is writable the kernels compile in memory once per process, with no error.
``QDENSITY_NUMBA_CACHE=0`` switches the disk cache off.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

__all__ = ["available", "numba", "cache_enabled", "jit"]

_OFF = ("0", "false", "no", "off")

try:
    if os.environ.get("QDENSITY_NUMBA", "1").strip().lower() in _OFF:
        raise ImportError("disabled by QDENSITY_NUMBA")
    import numba
except ImportError:  # pragma: no cover - exercised with QDENSITY_NUMBA=0
    numba = None  # type: ignore[assignment]  # optional: callers check available() first


def available() -> bool:
    """True when numba is installed and not disabled by ``QDENSITY_NUMBA=0``."""
    return numba is not None


def cache_enabled() -> bool:
    """False when ``QDENSITY_NUMBA_CACHE`` is ``0`` (or ``false``, ``no``, ``off``)."""
    return os.environ.get("QDENSITY_NUMBA_CACHE", "1").strip().lower() not in _OFF


def jit(**options: Any) -> Callable[[Callable], Callable]:
    """``numba.njit(**options)`` with the on-disk cache where numba can write one.

    Parameters
    ----------
    **options
        numba's ``njit`` options (``fastmath``, ``parallel``, ``inline``, ...); ``cache`` is
        chosen here: on unless :func:`cache_enabled` is False or numba finds no writable cache
        folder for the module (numba then refuses ``cache=True`` with a ``RuntimeError``, and
        the kernel compiles in memory instead).

    Returns
    -------
    callable
        A decorator; only call it when :func:`available` is True.
    """
    def decorate(func: Callable) -> Callable:
        if cache_enabled():
            try:
                return numba.njit(cache=True, **options)(func)
            except RuntimeError:  # no writable cache folder: a read-only install, no home
                pass
        return numba.njit(**options)(func)
    return decorate


