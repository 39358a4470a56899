"""Atomic file writes: a temporary file in the target folder, then :func:`os.replace`."""
from __future__ import annotations

import os
import secrets
from pathlib import Path

from ..errors import MeshWriteError, VesselError

__all__ = ["atomic_write"]


def atomic_write(path, writer, *, binary=False):
    """Write a file atomically: ``writer(fh)`` fills a temporary file, then it is renamed.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist.
    writer : callable
        Called with an open file object (text, UTF-8, or binary).
    binary : bool
        Open the temporary file in binary mode.

    Raises
    ------
    MeshWriteError
        The folder is missing or the write failed; nothing is left behind and
        an existing file at ``path`` is untouched.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "a.txt")
    >>> atomic_write(p, lambda fh: fh.write("hello\\n"))
    >>> open(p).read()
    'hello\\n'
    """
    p = Path(os.fspath(path))
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise MeshWriteError(f"{p}: folder {folder} does not exist; create it first")
    fd, tmp = _create_temporary(p, folder)
    try:
        with os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            writer(fh)
            fh.flush()
            os.fsync(fh.fileno())
        if p.exists():  # a replaced file keeps its permissions, as with open(path, "w")
            os.chmod(tmp, p.stat().st_mode & 0o7777)
        os.replace(tmp, p)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if not isinstance(exc, Exception) or isinstance(exc, VesselError):
            raise
        raise MeshWriteError(
            f"{p}: writing failed ({type(exc).__name__}: {exc}); nothing was written, "
            "any existing file is unchanged"
        ) from exc


def _create_temporary(p, folder):
    """A new hidden file beside ``p``, created with mode 0o666 so the process umask applies.

    (:func:`tempfile.mkstemp` creates 0o600, and reading the umask means
    changing it process-wide; ``os.open`` with O_EXCL and a random name does neither.)
    """
    for _ in range(100):
        tmp = folder / f".{p.name}.{secrets.token_hex(6)}.tmp"
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666), tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise MeshWriteError(f"{p}: cannot create a file in {folder} ({exc}); check permissions") from None
    raise MeshWriteError(f"{p}: cannot create a unique temporary file in {folder}; clean up its .*.tmp files")
