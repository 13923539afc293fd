"""How the declared constraints read and show values: numpy scalars as the Python values they
mean, and a value cut to a readable length for an error message."""

from __future__ import annotations

import os

import numpy as np

__all__ = ["_python_scalar", "_ScalarMixin", "_show"]


def _python_scalar(value):
    """A numpy scalar (``np.int64(3)``, ``np.float32(0.5)``, ``np.str_``) as its Python value."""
    return value.item() if isinstance(value, np.generic) else value


class _ScalarMixin:
    """Numpy scalars mean their Python values: accepted, and handed to the body as those."""

    def normalise(self, value):
        return _python_scalar(value)


def _show(value, width: int = 80) -> str:
    """``repr`` of ``value`` cut to ``width`` characters (arrays by shape and dtype when big;
    a path is shown whole up to 1,000 characters: the user needs to see which file)."""
    if isinstance(value, os.PathLike) or (isinstance(value, str) and os.sep in value):
        width = max(width, 1000)
    if isinstance(value, np.ndarray) and value.size > 16:
        return f"array of shape {value.shape} and dtype {value.dtype}"
    own_repr: object = type(value).__repr__
    if own_repr is object.__repr__:  # no repr of its own: say what it is
        name = getattr(value, "name", None)
        return f"{type(value).__name__}" + (f" {name!r}" if isinstance(name, str) else "")
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a broken __repr__ must not hide the real error
        text = f"<{type(value).__name__}>"
    return text if len(text) <= width else text[: width - 3] + "..."
