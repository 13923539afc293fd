"""Atomic file writes: every file the project writes goes through here.

A file is written to a temporary file in the folder of its destination, flushed to disk
(``os.fsync``) and moved over the destination with ``os.replace``, an atomic rename on POSIX
and Windows. A write that fails part way (a full disk, a file-size limit, an exception in the
caller's code, ``KeyboardInterrupt``) removes the temporary file and leaves the old file, if
there was one, byte for byte as it was; readers never see a half-written file.

:func:`atomic_write` hands the caller an open file; :func:`atomic_path` hands it the temporary
path (for writers that take a file name and read the format off its suffix, such as
matplotlib's ``savefig`` or ``zipfile``); :func:`atomic_write_text` and
:func:`atomic_write_bytes` write a whole string or byte string. The new file gets the mode of
the file it replaces (a new file: ``0o666`` less the umask, as ``open`` gives), and a symbolic
link is written through (its target is replaced, the link kept). A destination that exists
and is not a regular file (``/dev/null``, a FIFO, a terminal) cannot be replaced by a rename:
it is written in place.

Readers check what they are given before they read: :func:`check_readable` refuses a path that
is not a regular file (``/dev/zero`` reads forever, a FIFO blocks until a writer comes) or is
larger than the reader allows, and :func:`check_npz` refuses an ``.npz`` archive whose members
would inflate past a bound, or whose ``.npy`` headers claim more data than the member holds
(numpy allocates the header's shape before it reads), before anything is inflated.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from qdensity.validation import FilePath, Instance, Interval, Options, validates

__all__ = ["atomic_write", "atomic_path", "atomic_write_text", "atomic_write_bytes",
           "check_readable", "check_npz"]

_MODES = ("w", "wb", "x", "xb")


def _destination(path: str | os.PathLike) -> tuple[str, os.stat_result | None]:
    """The file to replace (a symbolic link resolved to its target) and its ``stat``."""
    target = os.fspath(path)
    if os.path.islink(target):
        target = os.path.realpath(target)
    try:
        return target, os.stat(target)
    except FileNotFoundError:
        return target, None


def _temporary(target: str) -> tuple[str, int]:
    """A new file beside ``target`` (``.<name>.<random>.tmp<suffix>``; the suffix kept so that
    writers which read the format off the name still see it) and its descriptor."""
    folder, name = os.path.split(target)
    suffix = os.path.splitext(name)[1]
    for _ in range(100):
        tmp = os.path.join(folder, f".{name}.{secrets.token_hex(4)}.tmp{suffix}")
        try:  # 0o666 less the umask, as open() creates files
            return tmp, os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL
                                | getattr(os, "O_BINARY", 0), 0o666)
        except FileExistsError:
            continue
    raise FileExistsError(f"could not create a temporary file beside {target!r}")


def _sync_folder(folder: str) -> None:
    """``fsync`` a folder so that the rename itself is on disk (POSIX; best effort)."""
    try:
        fd = os.open(folder or ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _discard(tmp: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(tmp)


@contextlib.contextmanager
@validates(path=FilePath(exists=None))
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write, moved over ``path`` when the ``with`` block succeeds.

    For writers that open the file themselves (``fig.savefig(tmp)``,
    ``zipfile.ZipFile(tmp, "w")``); the temporary name ends with ``path``'s suffix.

    Parameters
    ----------
    path : str or os.PathLike
        The destination; its folder must exist.

    Yields
    ------
    pathlib.Path
        The temporary file (created empty) in the destination's folder.

    Raises
    ------
    OSError
        Whatever creating, writing, syncing or renaming raised (a full disk: ``ENOSPC``; a
        size limit: ``EFBIG``); the old file is untouched and the temporary file removed.

    Examples
    --------
    >>> import os, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> with atomic_path(os.path.join(folder, "a.txt")) as tmp:
    ...     _ = tmp.write_text("new")
    >>> open(os.path.join(folder, "a.txt")).read(), os.listdir(folder)
    ('new', ['a.txt'])
    """
    target, old = _destination(path)
    if old is not None and stat.S_ISDIR(old.st_mode):
        raise IsADirectoryError(f"path {target!r} is a folder, not a file to write")
    if old is not None and not stat.S_ISREG(old.st_mode):
        yield Path(target)  # a device or FIFO: no rename can replace it; written in place
        return
    tmp, fd = _temporary(target)
    os.close(fd)
    try:
        yield Path(tmp)
        fd = os.open(tmp, os.O_RDWR | getattr(os, "O_BINARY", 0))
        try:
            os.fsync(fd)
            if old is not None and hasattr(os, "fchmod"):  # the replaced file's mode
                os.fchmod(fd, stat.S_IMODE(old.st_mode))
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        _discard(tmp)
        raise
    _sync_folder(os.path.dirname(target))


@contextlib.contextmanager
@validates(path=FilePath(exists=None), mode=Options(_MODES), encoding=[None, Instance(str)],
           newline=[None, Options(("", "\n", "\r", "\r\n"))])
def atomic_write(path: str | os.PathLike, mode: str = "w", *, encoding: str | None = "utf-8",
                 newline: str | None = None) -> Iterator[IO[Any]]:
    """An open file that replaces ``path`` when the ``with`` block succeeds (all or nothing).

    Parameters
    ----------
    path : str or os.PathLike
        The destination; its folder must exist.
    mode : {"w", "wb", "x", "xb"}
        Text or binary; ``"x"`` refuses a destination that exists (``FileExistsError``).
    encoding : str or None
        Of a text file (UTF-8 unless told).
    newline : str or None
        As for :func:`open` (``""`` for the ``csv`` module).

    Yields
    ------
    file object
        Open for writing, in the destination's folder.

    Raises
    ------
    OSError
        Whatever writing raised; the old file is untouched and the temporary file removed.

    Examples
    --------
    >>> import json, os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.json")
    >>> with atomic_write(path) as fh:
    ...     json.dump({"seeds": [0, 1]}, fh)
    >>> open(path).read()
    '{"seeds": [0, 1]}'
    """
    if mode.startswith("x") and os.path.lexists(path):
        raise FileExistsError(f"path {os.fspath(path)!r} exists (mode {mode!r} refuses it)")
    binary = mode.endswith("b")
    with atomic_path(path) as tmp:
        with open(tmp, "wb" if binary else "w", encoding=None if binary else encoding,
                  newline=None if binary else newline) as fh:
            yield fh
            fh.flush()


@validates(path=FilePath(exists=None), text=Instance(str), encoding=Instance(str))
def atomic_write_text(path: str | os.PathLike, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write`); returns the path.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "a.md")
    >>> atomic_write_text(path, "# title\\n").read_text()
    '# title\\n'
    """
    with atomic_write(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


@validates(path=FilePath(exists=None), data=Instance((bytes, bytearray, memoryview),
                                                          "a bytes-like object"))
def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`); returns the path.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = atomic_write_bytes(pathlib.Path(tempfile.mkdtemp()) / "x.bin", b"qdensity")
    >>> path.read_bytes()
    b'qdensity'
    """
    with atomic_write(path, "wb") as fh:
        fh.write(data)
    return Path(path)


@validates(path=FilePath(exists=None), name=Instance(str),
           max_bytes=[Interval(int, 0), None])
def check_readable(path: str | os.PathLike, name: str = "path", *,
                   max_bytes: int | None = None) -> Path:
    """Refuse, before opening it, a path a reader must not read: a device, FIFO or socket
    (``/dev/zero`` would be read until memory runs out, a FIFO blocks until a writer comes), or
    a file of more than ``max_bytes`` bytes. A path that does not exist, or a folder, is left to
    the reader's own ``open`` (``FileNotFoundError``, ``IsADirectoryError``).

    Parameters
    ----------
    path : str or os.PathLike
    name : str
        The argument named in the message.
    max_bytes : int, optional
        Largest file size the reader accepts.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        Naming ``name``, the path and what it is.

    Examples
    --------
    >>> check_readable("/dev/zero")
    Traceback (most recent call last):
    ...
    ValueError: path must be a regular file, got '/dev/zero' (a character device: it would be \
read forever or block)
    """
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return Path(path)
    mode = info.st_mode
    if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        what = ("a character device" if stat.S_ISCHR(mode) else "a block device"
                if stat.S_ISBLK(mode) else "a FIFO" if stat.S_ISFIFO(mode) else "a socket"
                if stat.S_ISSOCK(mode) else "not a regular file")
        raise ValueError(f"{name} must be a regular file, got {os.fspath(path)!r} ({what}: it "
                         f"would be read forever or block)")
    if max_bytes is not None and stat.S_ISREG(mode) and info.st_size > max_bytes:
        raise ValueError(f"{name} {os.fspath(path)!r} has {info.st_size} bytes, more than the "
                         f"{max_bytes} this reader accepts")
    return Path(path)


@validates(path=FilePath(exists=None), max_bytes=Interval(int, 0),
           max_members=Interval(int, 1))
def check_npz(path: str | os.PathLike, max_bytes: int, *, max_members: int = 10_000) -> None:
    """Refuse an ``.npz`` archive before ``numpy.load`` inflates or allocates anything.

    Checks, from the zip directory and each member's ``.npy`` header alone: at most
    ``max_members`` members, their sizes (``ZipInfo.file_size``) summing to at most
    ``max_bytes``, and no header claiming a shape whose data (shape times item size) is larger
    than its member (numpy allocates the header's shape first, so a 1 kB member claiming
    ``(10**12,)`` would ask for terabytes). Headers that need pickle (object arrays) are
    refused too.

    Parameters
    ----------
    path : str or os.PathLike
        The archive (a regular file: see :func:`check_readable`).
    max_bytes : int
        Most bytes the inflated arrays may take.
    max_members : int
        Most arrays the archive may hold.

    Raises
    ------
    ValueError
        Naming the path and the member: not a zip archive, too many or too large members, a
        header that is not a ``.npy`` header or claims more than its member holds.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.npz"
    >>> np.savez(path, w=np.zeros(100))
    >>> check_npz(path, max_bytes=10_000)  # 800 bytes of float64 and a header: accepted
    >>> check_npz(path, max_bytes=100)
    Traceback (most recent call last):
        ...
    ValueError: '...a.npz': its arrays inflate to 928 bytes, more than the 100 allowed; ...
    """
    where = repr(os.fspath(path))
    check_readable(path)
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            if len(infos) > max_members:
                raise ValueError(f"{where} holds {len(infos)} arrays, more than {max_members}")
            total = sum(info.file_size for info in infos)
            if total > max_bytes:
                raise ValueError(f"{where}: its arrays inflate to {total} bytes, more than the "
                                 f"{max_bytes} allowed; refused before inflating")
            for info in infos:
                try:
                    with zf.open(info) as member:
                        version = np.lib.format.read_magic(member)
                        shape, _, dtype = (np.lib.format.read_array_header_1_0(member)
                                           if version == (1, 0)
                                           else np.lib.format.read_array_header_2_0(member))
                except ValueError as exc:
                    raise ValueError(f"{where}: member {info.filename!r} is not a .npy array "
                                     f"readable without pickle: {exc}") from exc
                if dtype.hasobject:
                    raise ValueError(f"{where}: member {info.filename!r} holds Python objects, "
                                     f"not readable without pickle (which is never used)")
                claimed = int(np.prod(shape, dtype=object)) * dtype.itemsize
                if claimed > info.file_size:
                    raise ValueError(f"{where}: member {info.filename!r} claims shape {shape} of "
                                     f"{dtype} ({claimed} bytes), more than its {info.file_size} "
                                     f"bytes")
    except (zipfile.BadZipFile, OSError, EOFError, zlib.error) as exc:
        raise ValueError(f"{where} is not a readable .npz archive: {exc}") from exc
