"""Walk a log archive: every log (as ``logcal analyze FOLDER`` finds them), its settings from
the ``logcal.toml`` files above it, and its content hash.

The hash is SHA-256 over the file's bytes (a rosbag2 folder: over its files' relative names and
bytes, sorted), so that a rerun can tell a changed log from a finished one without trusting
modification times (copies and ``rsync`` reset them).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from logtools.batch.settings import LogSettings, SettingsError, settings_for
from logtools.errors import LogcalInputError
from logtools.runs import LOG_SUFFIXES

__all__ = ["LogJob", "content_hash", "find_logs", "log_id"]

_CHUNK = 1 << 20


@dataclass(frozen=True)
class LogJob:
    """One log of the archive, ready to be analysed.

    Attributes:
        rel: path relative to the archive (POSIX separators): the log's name in every output.
        path: absolute path.
        id: file-name-safe identifier of ``rel`` (outputs are ``logs/<id>.json`` ...).
        content_hash: SHA-256 of the log's content.
        settings: its ``logcal.toml`` settings; None when ``settings_error`` says why not.
        settings_error: the message of a ``logcal.toml`` that cannot be used.
    """

    rel: str
    path: str
    id: str
    content_hash: str
    settings: LogSettings | None
    settings_error: str | None = None


def _is_rosbag2(p: Path) -> bool:
    return p.is_dir() and (p / "metadata.yaml").is_file()


def content_hash(path: Path) -> str:
    """SHA-256 (hex) of a log file, or of a rosbag2 folder's files (names and bytes)."""
    digest = hashlib.sha256()
    files = [path] if path.is_file() else sorted(q for q in path.rglob("*") if q.is_file())
    for f in files:
        if f is not path:
            digest.update(f.relative_to(path).as_posix().encode("utf-8", "surrogateescape"))
            digest.update(b"\0")
        with f.open("rb") as fh:
            while chunk := fh.read(_CHUNK):
                digest.update(chunk)
    return digest.hexdigest()


def log_id(rel: str) -> str:
    """A file-name-safe, unique id of the relative path ``rel``: its readable characters
    (others replaced by ``_``, at most 60) and 10 hex digits of its SHA-1."""
    keep = "".join(c if c.isascii() and (c.isalnum() or c in "._-") else "_" for c in rel)
    keep = keep.strip("._") or "log"
    return f"{keep[:60]}-{hashlib.sha1(rel.encode('utf-8', 'surrogateescape')).hexdigest()[:10]}"


def _walk(archive: Path, skip: tuple[Path, ...]) -> list[Path]:
    found: list[Path] = []
    for q in sorted(archive.rglob("*")):
        if any(q == s or s in q.parents for s in skip):
            continue
        if any(part.startswith(".") for part in q.relative_to(archive).parts):
            continue
        in_bag = any(_is_rosbag2(parent) for parent in q.parents if archive in parent.parents)
        if _is_rosbag2(q) or (q.is_file() and q.suffix.lower() in LOG_SUFFIXES and not in_bag):
            found.append(q)
    return found


def _printable(text: str) -> str:
    """``text`` with bytes that are not UTF-8 (undecodable file names) shown as U+FFFD."""
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def find_logs(archive: Path, *, skip: tuple[Path, ...] = ()) -> list[LogJob]:
    """Every log below ``archive`` (``.mcap``, ``.csv``, ``.bag`` files and rosbag2 folders;
    hidden files and folders, and anything under ``skip``, left out), sorted by path.

    Raises:
        LogcalInputError: ``archive`` is not a folder.
    """
    archive = archive.resolve()
    if not archive.is_dir():
        raise LogcalInputError(f"{archive}: not a folder; expected an archive of logs "
                               f"({', '.join(LOG_SUFFIXES)} files, rosbag2 folders).")
    skip = tuple(s.resolve() for s in skip)
    cache: dict[Path, dict[str, str]] = {}
    jobs: list[LogJob] = []
    for p in _walk(archive, skip):
        rel = _printable(p.relative_to(archive).as_posix())
        settings, error = None, None
        try:
            settings = settings_for(archive, p, cache)
        except SettingsError as err:
            error = str(err)
        jobs.append(LogJob(rel, str(p), log_id(rel), content_hash(p), settings, error))
    return jobs
