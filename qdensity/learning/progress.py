"""Progress bars for long runs (training, sweeps, experiments): tqdm, only on a terminal.

:func:`progress_bar` returns a ``tqdm`` bar when ``verbose`` is true and the stream is a
terminal (tqdm's own ``disable=None`` rule), and a bar that does nothing otherwise, so a run
under pytest, in a pipe or in a log file prints nothing. Callers report loss, metric and shots
spent with ``bar.set_postfix(...)``.
"""

from __future__ import annotations

import sys
from typing import Any

from tqdm.auto import tqdm

__all__ = ["progress_bar"]


def progress_bar(total: int | None, *, desc: str = "", verbose: bool = True, unit: str = "it",
                 file=None, leave: bool = False) -> Any:
    """A tqdm bar on a terminal when ``verbose``; silent otherwise.

    Parameters
    ----------
    total : int or None
        Expected number of updates (None: unknown).
    desc : str
        Prefix of the bar.
    verbose : bool
        False: never show a bar.
    unit : str
    file : text stream, optional
        Default ``sys.stderr``; a bar is shown only if ``file.isatty()``.
    leave : bool
        Keep the finished bar on screen.

    Returns
    -------
    tqdm.tqdm
        Use ``update(n)``, ``set_postfix(...)`` and ``close()`` (or ``with``).

    Examples
    --------
    >>> import io
    >>> with progress_bar(3, desc="fit", file=io.StringIO()) as bar:  # not a terminal: silent
    ...     bar.update(3)
    ...     bar.disable
    True
    """
    stream = sys.stderr if file is None else file
    return tqdm(total=total, desc=desc, unit=unit, file=stream, leave=leave,
                disable=None if verbose else True, dynamic_ncols=True)
