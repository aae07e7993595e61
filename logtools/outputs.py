"""Files logcal writes: checked before any work is done, never an input, written atomically.

An output path must have the suffix of what is written (``--rrd x.png`` would lose the
recording), must not be a directory, must sit in an existing writable directory that is not on
a special file system (``/proc``, ``/sys``, ``/dev``: refused before the work, not after it),
and must not be one of the logs being read (``analyze in.mcap --rrd in.mcap`` would replace the
drive log).

Writes go to a temporary file beside the target created by ``tempfile.mkstemp``: a random name
opened with ``O_CREAT | O_EXCL`` (a link or file planted at that name makes the creation fail
and another name is drawn; it is never followed), then written and renamed over the target
(``os.replace`` replaces a link at the target, it never writes through it). The temporary file
is flushed to the disk (``fsync``) before the rename and the folder after it, so that a kill or
a power cut leaves the old target or the new one, never a mix or an empty file. An interrupted
run never leaves a half-written target; its temporary ``.<name>.partial-XXXXXXXX<suffix>``
stays (a failed write removes it).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

from logtools.errors import LogcalInputError

__all__ = [
    "PARTIAL_MARK",
    "OutputPathError",
    "check_output",
    "fsync_folder",
    "fsync_path",
    "special_devices",
    "special_filesystem",
    "write_atomically",
]

T = TypeVar("T")

PARTIAL_MARK = ".partial-"
"""Part of every temporary file's name (``.<name>.partial-XXXXXXXX<suffix>``), for clean-ups."""

SPECIAL_ROOTS = (Path("/proc"), Path("/sys"), Path("/dev"))
"""Kernel file systems: never an output (and never read as a log by ``logcal batch``)."""


class OutputPathError(LogcalInputError):
    """An output path logcal will not write.

    Attributes:
        option: the command-line option or role of the path (``--rrd``).
        path: the path given.
        reason: why it is refused.
    """

    def __init__(self, option: str, path: Path, reason: str) -> None:
        self.option, self.path, self.reason = option, path, reason
        super().__init__(f"{option} {path}: {reason}")


def special_devices() -> set[int]:
    """The devices (``st_dev``) of ``/proc``, ``/sys`` and ``/dev``."""
    devs = set()
    for root in SPECIAL_ROOTS:
        try:
            devs.add(os.stat(root).st_dev)
        except OSError:
            continue
    return devs


def special_filesystem(path: Path) -> Path | None:
    """The kernel file system (``/proc``, ``/sys``, ``/dev``) that ``path`` is on, or None.

    Decided by the resolved path (links followed) and by the device of its nearest existing
    folder (a bind mount of ``/proc`` elsewhere is on ``/proc``'s device)."""
    resolved = path.resolve()
    for root in SPECIAL_ROOTS:
        if resolved == root or root in resolved.parents:
            return root
    existing = resolved
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    try:
        dev = os.stat(existing).st_dev
    except OSError:
        return None
    for root in SPECIAL_ROOTS:
        try:
            if os.stat(root).st_dev == dev:
                return root
        except OSError:
            continue
    return None


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_output(
    path: Path, *, option: str, suffixes: tuple[str, ...], inputs: Iterable[Path] = ()
) -> Path:
    """``path`` if logcal may write it (see the module docstring).

    Raises:
        OutputPathError: wrong suffix, a directory, no such or unwritable directory, on a
            special file system, or one of ``inputs`` (also below an input folder, e.g. inside
            a rosbag2 folder).
    """
    if path.suffix.lower() not in suffixes:
        raise OutputPathError(
            option, path, f"expected a file name ending in {' or '.join(suffixes)}."
        )
    if path.is_dir():
        raise OutputPathError(option, path, "is a directory; expected a file name.")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise OutputPathError(option, path, f"the directory {parent} does not exist.")
    special = special_filesystem(path)
    if special is not None:
        raise OutputPathError(
            option,
            path,
            f"is on the kernel file system {special}, where "
            "logcal writes nothing; choose a folder on disk.",
        )
    if not os.access(parent, os.W_OK):
        raise OutputPathError(option, path, f"the directory {parent} is not writable.")
    target = path.resolve()
    for given in inputs:
        src = Path(given).resolve()
        if target == src or _same_file(target, src) or src in target.parents:
            raise OutputPathError(
                option,
                path,
                f"is the input log {given} (or inside it); logcal never "
                "overwrites an input. Choose another name.",
            )
    return path


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def fsync_path(path: Path) -> None:
    """Flush the file ``path`` to the disk (its data and size)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_folder(folder: Path) -> None:
    """Flush ``folder``'s entries (a rename in it) to the disk; a file system that cannot sync
    a folder (some network ones) is left as it is."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(path: Path, write: Callable[[Path], T]) -> T:
    """Call ``write(tmp)`` on a temporary file beside ``path`` (same suffix), created
    exclusively by :func:`tempfile.mkstemp` with the permissions a new file would get, flush it
    to the disk, then rename it over ``path`` and flush the folder; the temporary file is
    removed when ``write`` (or the flush) fails: a full disk leaves the old ``path``."""
    parent = path.parent if str(path.parent) else Path(".")
    fd, name = tempfile.mkstemp(
        prefix=f".{path.name[:80]}{PARTIAL_MARK}", suffix=path.suffix, dir=parent
    )
    tmp = Path(name)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
    finally:
        os.close(fd)
    try:
        out = write(tmp)
        fsync_path(tmp)
        os.replace(tmp, path)
        fsync_folder(parent)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return out
