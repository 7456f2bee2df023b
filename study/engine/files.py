"""Reading a file a user or another process may have replaced by something else.

A cache block, a measurement file or a spec is read only if it is a regular file of
bounded size: it is opened without blocking (a FIFO would wait for a writer forever),
optionally without following a symbolic link, checked with ``fstat`` (a folder, a
device such as ``/dev/zero`` or a socket is refused before a byte is read), and never
read beyond its limit. Each caller turns the :class:`RefusedFile` subclasses into its
own one-line message (a quarantined cache block, a measurement or spec error).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import BinaryIO

__all__ = [
    "GrewWhileRead",
    "NotRegularFile",
    "RefusedFile",
    "SymbolicLink",
    "TooLarge",
    "file_kind",
    "open_regular",
    "read_regular",
]


class RefusedFile(Exception):
    """A file that is not read; the subclass says why."""


class SymbolicLink(RefusedFile):
    """A symbolic link, opened with ``follow_links=False``."""


class NotRegularFile(RefusedFile):
    """A folder, FIFO, device or socket; :attr:`kind` names it."""

    def __init__(self, kind: str) -> None:
        super().__init__(kind)
        self.kind = kind


class TooLarge(RefusedFile):
    """A file of more bytes than allowed; :attr:`size` [bytes]."""

    def __init__(self, size: int) -> None:
        super().__init__(size)
        self.size = size


class GrewWhileRead(RefusedFile):
    """A file that grew beyond its limit while it was read."""


def file_kind(mode: int) -> str:
    """Words for what a file mode is: ``"a folder"``, ``"a FIFO"``..."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return name
    return "not a regular file"


def open_regular(path: str | Path, limit: int, *, follow_links: bool = False) -> BinaryIO:
    """``path`` opened for binary reading if it is a regular file of at most ``limit``
    bytes.

    Parameters
    ----------
    path : path
        The file.
    limit : int
        Largest size allowed [bytes].
    follow_links : bool
        Follow a symbolic link (default: refuse it, ``O_NOFOLLOW``).

    Raises
    ------
    SymbolicLink, NotRegularFile, TooLarge
        Before a byte is read.
    OSError
        If it cannot be opened (missing, no permission...).
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    if not follow_links:
        flags |= os.O_NOFOLLOW
    try:
        handle = os.open(path, flags)
    except OSError as err:
        if err.errno == errno.ELOOP and not follow_links:
            raise SymbolicLink(str(path)) from None
        raise
    try:
        info = os.fstat(handle)
        if not stat.S_ISREG(info.st_mode):
            raise NotRegularFile(file_kind(info.st_mode))
        if info.st_size > limit:
            raise TooLarge(info.st_size)
        os.set_blocking(handle, True)
        return os.fdopen(handle, "rb")
    except BaseException:
        os.close(handle)
        raise


def read_regular(path: str | Path, limit: int, *, follow_links: bool = False) -> bytes:
    """All bytes of ``path``, a regular file of at most ``limit`` bytes (see
    :func:`open_regular`; :class:`GrewWhileRead` if it grew beyond while read)."""
    with open_regular(path, limit, follow_links=follow_links) as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise GrewWhileRead(str(path))
    return data
