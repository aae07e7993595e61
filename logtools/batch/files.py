"""Reading regular files only: what every part of a batch that opens a file from the archive or
the output folder goes through (the archive walk, ``logcal.toml``, the manifest and journal).

A file is opened with ``O_NOFOLLOW | O_NONBLOCK`` (a link is refused, a FIFO does not block the
open) and checked with ``fstat`` to be regular before a byte is read. This module imports
nothing else of the batch, so :mod:`~logtools.batch.archive` and
:mod:`~logtools.batch.settings` both use it without importing each other.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__ = ["SETTINGS_MAX_BYTES", "file_kind", "open_regular", "read_regular"]

SETTINGS_MAX_BYTES = 1 << 20
"""A ``logcal.toml``, channel map or URDF larger than this is refused (1 MiB)."""


def file_kind(mode: int) -> str:
    """What a file of ``mode`` is, in words (``a FIFO``, ``a symbolic link``...)."""
    kinds = (
        (stat.S_ISREG, "a regular file"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((text for test, text in kinds if test(mode)), "a special file")


def open_regular(path: str | Path, *, special: set[int] | None = None) -> int:
    """A read-only file descriptor of ``path`` if it is a regular file and not a link.

    Opened with ``O_NOFOLLOW | O_NONBLOCK`` (a link is refused, a FIFO does not block the
    open), then checked with ``fstat``: a FIFO, socket or device is closed unread, and so is a
    file on a kernel file system whose device is in ``special``.

    Raises:
        OSError: it cannot be opened, or is not a regular file (``EINVAL``, with its kind).
    """
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    fd = os.open(path, flags)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(
                errno.EINVAL, f"it is {file_kind(st.st_mode)}; logcal reads regular files only"
            )
        if special and st.st_dev in special:
            raise OSError(errno.EINVAL, "it is on a kernel file system (/proc, /sys, /dev)")
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_regular(path: str | Path, limit: int = SETTINGS_MAX_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (not a link, at most ``limit`` bytes).

    Raises:
        OSError: not a regular file, a link, unreadable, or larger than ``limit``.
    """
    fd = open_regular(path)
    with os.fdopen(fd, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise OSError(errno.EFBIG, f"larger than {limit} bytes")
    return data
