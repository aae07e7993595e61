"""Command-line log arguments to a list of runs: files as given, folders expanded.

A folder holding a ``metadata.yaml`` is one rosbag2 run; any other folder contributes its
logs (``.mcap``, ``.csv``, ``.bag``, and rosbag2 folders below it), sorted by name. The walk
never follows a link to a folder, lists regular files only (a FIFO named ``x.csv`` is not a
log), and a folder it cannot list (deeper than ``PATH_MAX``, no permission) is a clean error
naming it, not a traceback. (``logcal batch`` walks archives with
:func:`logtools.batch.archive.find_logs`, which also refuses links to files.)
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from logtools.errors import LogcalInputError
from logtools.readers.formats import log_suffixes, skipped

__all__ = ["LOG_SUFFIXES", "expand_runs", "short_names"]

LOG_SUFFIXES = log_suffixes()
"""The built-in formats' suffixes at import (the archive walk's; ``log_suffixes()`` also counts
formats registered later)."""


def _is_rosbag2(p: Path) -> bool:
    return p.is_dir() and (p / "metadata.yaml").is_file()


def _walk(folder: Path) -> list[Path]:
    """The logs below ``folder`` (links to folders not followed).

    Raises:
        LogcalInputError: a folder below it cannot be listed.
    """

    def _fail(err: OSError) -> None:
        raise LogcalInputError(
            f"{err.filename}: cannot list this folder ({err.strerror or err})"
        ) from err

    try:
        return _walk_unchecked(folder, _fail)
    except OSError as err:  # a path too long to test (ENAMETOOLONG) below a listed folder
        _fail(err)
        raise


def _walk_unchecked(folder: Path, fail: Callable[[OSError], None]) -> list[Path]:
    found: list[Path] = []
    for here, dirs, files in os.walk(folder, onerror=fail, followlinks=False):
        base = Path(here)
        if base != folder and _is_rosbag2(base):
            dirs[:] = []
            continue
        for d in dirs:
            if _is_rosbag2(base / d) and not (base / d).is_symlink():
                found.append(base / d)
        for f in files:
            q = base / f
            if (
                q.suffix.lower() in log_suffixes()
                and q.is_file()
                and not _is_rosbag2(base)
                and not skipped(q)
            ):
                found.append(q)
    return found


def expand_runs(paths: Sequence[Path]) -> list[Path]:
    """Files as given; folders replaced by the runs they hold.

    Raises:
        LogcalInputError: a path does not exist, or a folder holds no log.
    """
    out: list[Path] = []
    for p in paths:
        if not p.exists():
            raise LogcalInputError(f"{p}: no such file or folder")
        if p.is_file() or _is_rosbag2(p):
            out.append(p)
            continue
        found = sorted(_walk(p))
        if not found:
            raise LogcalInputError(
                f"{p}: the folder holds no log ({', '.join(log_suffixes())} files or rosbag2 "
                "folders with a metadata.yaml)"
            )
        out += found
    return out


def short_names(paths: list[str]) -> list[str]:
    """The shortest trailing part of each path (whole components) that tells the runs apart:
    ``.../square/231220200029/231220200029_run-02.csv`` -> ``231220200029_run-02.csv``."""
    parts = [p.replace("\\", "/").rstrip("/").split("/") for p in paths]
    for k in range(1, max((len(p) for p in parts), default=1) + 1):
        names = ["/".join(p[-k:]) for p in parts]
        if len(set(names)) == len(names):
            return names
    return list(paths)
