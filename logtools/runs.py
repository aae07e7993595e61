"""Command-line log arguments to a list of runs: files as given, folders expanded.

A folder holding a ``metadata.yaml`` is one rosbag2 run; any other folder contributes its
logs (``.mcap``, ``.csv``, ``.bag``, and rosbag2 folders below it), sorted by name.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from logtools.errors import LogcalInputError
from logtools.readers.optiodom import is_optiodom_metadata

__all__ = ["LOG_SUFFIXES", "expand_runs"]

LOG_SUFFIXES = (".mcap", ".csv", ".bag")


def _is_rosbag2(p: Path) -> bool:
    return p.is_dir() and (p / "metadata.yaml").is_file()


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
        found = sorted(
            q for q in p.rglob("*")
            if (q.is_file() and q.suffix.lower() in LOG_SUFFIXES
                and not _is_rosbag2(q.parent) and not is_optiodom_metadata(q))
            or _is_rosbag2(q)
        )
        if not found:
            raise LogcalInputError(
                f"{p}: the folder holds no log ({', '.join(LOG_SUFFIXES)} files or rosbag2 "
                "folders with a metadata.yaml)"
            )
        out += found
    return out
