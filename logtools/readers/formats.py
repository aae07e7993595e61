"""Log formats as plugins: each format a :class:`FormatReader` that recognises a path (its name,
its first bytes, or a folder's layout), reads it into per-topic frames, and names the file
suffixes an archive walk collects. ``read_log``, ``info``, ``analyze``, ``view``, ``batch`` and
the folder walks ask this registry; a new format adds a module of its own and one
``register_format`` call (or an entry point in the group ``logcal.formats`` naming a
``FormatReader``), and touches nothing else.

Registered here, in the order they are asked: rosbag2 folders, ROS 1 / rosbag2 files, MCAP,
OptiOdom session runs, TUM trajectories, CSV exports.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from pathlib import Path

from logtools.readers.builtin_formats import BUILTIN
from logtools.readers.format_reader import HEAD_BYTES, FormatReader, ReadRequest

__all__ = [
    "HEAD_BYTES",
    "FormatReader",
    "ReadRequest",
    "folder_runs",
    "format_for",
    "formats",
    "log_suffixes",
    "register_format",
    "skipped",
]

_REGISTRY: list[FormatReader] = []
_LOADED: list[bool] = []


def register_format(reader: FormatReader, *, first: bool = False) -> None:
    """Add ``reader`` to the registry (``first``: asked before the others, e.g. a format whose
    files also look like CSV). A reader of the same name replaces the old one."""
    _builtin()
    _REGISTRY[:] = [r for r in _REGISTRY if r.name != reader.name]
    if first:
        _REGISTRY.insert(0, reader)
    else:
        _REGISTRY.append(reader)


def formats() -> tuple[FormatReader, ...]:
    """Every registered format, in the order they are asked."""
    _builtin()
    return tuple(_REGISTRY)


def log_suffixes() -> tuple[str, ...]:
    """File suffixes of every format (what an archive walk collects)."""
    return tuple(dict.fromkeys(s for r in formats() for s in r.suffixes))


def format_for(path: Path, head: bytes = b"") -> FormatReader | None:
    """The first format that reads ``path`` (``head``: its first bytes; a file's are read when
    not given), or None."""
    if not head and path.is_file():
        try:
            with open(path, "rb", buffering=0) as fh:
                head = fh.read(HEAD_BYTES)
        except OSError:
            head = b""
    for reader in formats():
        if reader.folder != path.is_dir():
            continue
        if reader.sniff(path, head):
            return reader
    return None


def folder_runs(folder: Path) -> list[Path] | None:
    """The runs of a folder that a format reads as a set of runs (an OptiOdom session), or
    None when no format does."""
    for reader in formats():
        if reader.runs is not None:
            found = reader.runs(folder)
            if found:
                return found
    return None


def skipped(path: Path) -> bool:
    """Whether a file that carries a log suffix is not a log (a session's metadata)."""
    return any(r.skip is not None and r.skip(path) for r in formats())


def _builtin() -> None:
    if _LOADED:
        return
    _LOADED.append(True)
    _REGISTRY.extend(BUILTIN)
    for ep in entry_points(group="logcal.formats"):
        reader = ep.load()
        if isinstance(reader, FormatReader):
            _REGISTRY[:] = [r for r in _REGISTRY if r.name != reader.name]
            _REGISTRY.insert(0, reader)
