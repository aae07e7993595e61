"""Walk a log archive: every log (as ``logcal analyze FOLDER`` finds them), its settings from
the ``logcal.toml`` files above it, and its content hash.

A log is data, never instructions: the walk reads regular files inside the archive only.
Symbolic links are never followed (a link named like a log, or a link to a folder, becomes a
failed entry that says so, instead of being read under the archive's name); FIFOs, sockets and
devices are never opened (a failed entry names their kind); nothing on ``/proc``, ``/sys`` or
``/dev`` is read; a folder that cannot be listed (too deep for ``PATH_MAX``, no permission)
becomes a failed entry and the walk goes on. Each entry is isolated: whatever goes wrong with
one becomes that entry's error, never the batch's.

The hash is SHA-256 over the file's bytes (a rosbag2 folder: over its files' relative names and
bytes, sorted), so that a rerun can tell a changed log from a finished one without trusting
modification times (copies and ``rsync`` reset them). Files are opened with ``O_NOFOLLOW`` and
``O_NONBLOCK`` and checked with ``fstat`` to be regular before a byte is read.

Every log has an id (:func:`log_id`) derived from its path's *bytes*: two names that differ
only in bytes that are not UTF-8 have two ids, two records and two readable names.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

from logtools.batch.files import file_kind, open_regular
from logtools.batch.settings import (
    SETTINGS_FILE,
    LogSettings,
    SettingsCache,
    SettingsError,
    settings_for,
)
from logtools.errors import LogcalInputError
from logtools.outputs import special_devices, special_filesystem
from logtools.readers.formats import log_suffixes, skipped

__all__ = [
    "ID_PATTERN",
    "SETTINGS_FILE",
    "UNLISTED",
    "EntryError",
    "LogJob",
    "content_hash",
    "display_name",
    "file_kind",
    "find_logs",
    "log_id",
]

_CHUNK = 1 << 20
METADATA_FILE = "metadata.yaml"
ID_PATTERN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,60}-[0-9a-f]{10,64}")
"""What every log id looks like (:func:`log_id`); anything else in a manifest is not ours."""
UNLISTED = "cannot list this folder"
"""Start of the refusal of a folder of the archive that cannot be listed (its logs are not
seen, so a batch must not take them for gone)."""


@dataclass(frozen=True)
class LogJob:
    """One entry of the archive: a log ready to be analysed, or one that cannot be read.

    Attributes:
        rel: path relative to the archive (POSIX separators), readable: bytes that are not
            UTF-8 shown as ``\\xNN``. The log's name in every output (escaped there).
        path: absolute path (undecodable bytes kept, as ``os.fsdecode`` gives them).
        id: file-name-safe identifier of the path's bytes (outputs are ``logs/<id>.json``...).
        content_hash: SHA-256 of the log's content ("" for an entry that cannot be read).
        settings: its ``logcal.toml`` settings; None when ``settings_error`` or
            ``entry_error`` says why not.
        settings_error: the message of a ``logcal.toml`` that cannot be used.
        entry_error: why the entry is not read at all (a link, a FIFO, a folder that cannot
            be listed); the entry fails with this message.
    """

    rel: str
    path: str
    id: str
    content_hash: str
    settings: LogSettings | None
    settings_error: str | None = None
    entry_error: str | None = None


class EntryError(LogcalInputError):
    """An archive entry logcal does not read (link, special file, unreadable folder)."""


def _lstat(path: str) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except OSError:
        return None


def _is_rosbag2(path: str) -> bool:
    """A real folder (not a link) holding a ``metadata.yaml`` entry of any kind."""
    st = _lstat(path)
    return (
        st is not None
        and stat.S_ISDIR(st.st_mode)
        and _lstat(os.path.join(path, METADATA_FILE)) is not None
    )


def _hash_file(path: str, digest: hashlib._Hash, special: set[int]) -> None:
    fd = open_regular(path, special=special)
    with os.fdopen(fd, "rb", buffering=0) as fh:
        while chunk := fh.read(_CHUNK):
            digest.update(chunk)


def _rosbag2_files(folder: str) -> list[str]:
    """Relative names of a rosbag2 folder's files, sorted by bytes.

    Raises:
        EntryError: a link or special file inside it, or a subfolder that cannot be listed.
    """
    found: list[str] = []
    stack = [""]
    while stack:
        sub = stack.pop()
        here = os.path.join(folder, sub) if sub else folder
        try:
            with os.scandir(here) as it:
                entries = list(it)
        except OSError as err:
            raise EntryError(
                f"cannot list {sub or '.'} in the rosbag2 folder ({err.strerror or err})"
            ) from err
        for e in entries:
            rel = os.path.join(sub, e.name) if sub else e.name
            st = e.stat(follow_symlinks=False)
            if stat.S_ISDIR(st.st_mode):
                stack.append(rel)
            elif stat.S_ISREG(st.st_mode):
                found.append(rel)
            else:
                raise EntryError(
                    f"{display_name(rel)} in the rosbag2 folder is "
                    f"{file_kind(st.st_mode)}; logcal reads regular files only"
                )
    return sorted(found, key=os.fsencode)


def content_hash(path: Path | str, *, special: set[int] | None = None) -> str:
    """SHA-256 (hex) of a log file, or of a rosbag2 folder's files (names and bytes).

    Raises:
        EntryError: the log (or a file of the folder) is not a regular file, or is a link.
        OSError: it cannot be read.
    """
    name = os.fspath(path)
    special = special_devices() if special is None else special
    digest = hashlib.sha256()
    st = os.lstat(name)
    if stat.S_ISDIR(st.st_mode):
        for rel in _rosbag2_files(name):
            digest.update(os.fsencode(rel))
            digest.update(b"\0")
            _hash_file(os.path.join(name, rel), digest, special)
    else:
        _hash_file(name, digest, special)
    return digest.hexdigest()


def display_name(rel: str) -> str:
    """``rel`` readable: bytes that are not UTF-8 (kept by ``os.fsdecode`` as surrogates)
    shown as ``\\xNN``, so that two such names stay two names."""
    return os.fsencode(rel).decode("utf-8", "backslashreplace")


def log_id(rel: str | bytes, digits: int = 10) -> str:
    """A file-name-safe id of the relative path ``rel`` (its bytes: ``os.fsencode``): its
    readable characters (others replaced by ``_``, at most 60) and ``digits`` hex digits of the
    bytes' SHA-1 (10 by default; :func:`find_logs` lengthens the ids that would collide)."""
    raw = rel if isinstance(rel, bytes) else os.fsencode(rel)
    text = raw.decode("utf-8", "replace")
    keep = "".join(c if c.isascii() and (c.isalnum() or c in "._-") else "_" for c in text)
    keep = keep.strip("._") or "log"
    if digits <= 40:
        tail = hashlib.sha1(raw).hexdigest()[:digits]
    else:
        tail = hashlib.sha256(raw).hexdigest()[:digits]
    return f"{keep[:60]}-{tail}"


def _walk(
    archive: str, skip: set[tuple[int, int]], special: set[int]
) -> list[tuple[str, str | None]]:
    """(relative path, None) of every log, (relative path, why not) of every entry that is
    refused, sorted by bytes. Never follows a link; never raises for one entry.

    A file is a log when its suffix is one of the registered formats'
    (:func:`~logtools.readers.formats.log_suffixes`, format plugins included) and no format
    says it is not a log (:func:`~logtools.readers.formats.skipped`: an OptiOdom session's
    metadata)."""
    suffixes = frozenset(log_suffixes())
    found: list[tuple[str, str | None]] = []
    stack = [""]
    while stack:
        sub = stack.pop()
        here = os.path.join(archive, sub) if sub else archive
        try:
            with os.scandir(here) as it:
                entries = list(it)
        except OSError as err:
            why = errno.errorcode.get(err.errno or 0, "")
            found.append(
                (
                    sub,
                    f"{UNLISTED} ({err.strerror or err}"
                    f"{', ' + why if why else ''}); its logs are not analysed",
                )
            )
            continue
        for e in entries:
            if e.name.startswith("."):
                continue
            rel = os.path.join(sub, e.name) if sub else e.name
            try:
                st = e.stat(follow_symlinks=False)
            except OSError as err:
                found.append((rel, f"cannot stat it ({err.strerror or err})"))
                continue
            is_log_name = os.path.splitext(e.name)[1].lower() in suffixes
            if stat.S_ISLNK(st.st_mode):
                target_dir = os.path.isdir(e.path)  # stat of the target: never opened
                if is_log_name or target_dir:
                    found.append(
                        (
                            rel,
                            f"is a symbolic link{' to a folder' if target_dir else ''}"
                            "; logcal reads only regular files inside the archive "
                            "and never follows links",
                        )
                    )
                continue
            if st.st_dev in special:
                found.append((rel, "is on a kernel file system (/proc, /sys, /dev); not read"))
                continue
            if stat.S_ISDIR(st.st_mode):
                if (st.st_dev, st.st_ino) in skip:
                    continue
                if _is_rosbag2(e.path):
                    found.append((rel, None))
                else:
                    stack.append(rel)
            elif is_log_name:
                if stat.S_ISREG(st.st_mode):
                    if not skipped(Path(e.path)):  # e.g. a session's metadata, not a run
                        found.append((rel, None))
                else:
                    found.append(
                        (rel, f"is {file_kind(st.st_mode)}; logcal reads regular files only")
                    )
    return sorted(found, key=lambda item: [os.fsencode(p) for p in item[0].split(os.sep)])


def find_logs(archive: Path, *, skip: tuple[Path, ...] = ()) -> list[LogJob]:
    """Every log below ``archive`` (files with a registered format's suffix, ``.mcap``,
    ``.csv``, ``.bag``..., and rosbag2 folders; hidden files and folders, and anything under
    ``skip``, left out), sorted by path bytes; links, special files and unreadable folders as
    entries with ``entry_error``.

    Raises:
        LogcalInputError: ``archive`` is not a folder, or is on a kernel file system.
    """
    archive = archive.resolve()
    if not archive.is_dir():
        raise LogcalInputError(
            f"{archive}: not a folder; expected an archive of logs "
            f"({', '.join(log_suffixes())} files, rosbag2 folders)."
        )
    root = special_filesystem(archive)
    if root is not None:
        raise LogcalInputError(
            f"{archive}: is on the kernel file system {root}; expected an archive of logs on disk."
        )
    special = special_devices()
    skip_ids = set()
    for s in skip:
        st = _lstat(os.fspath(s.resolve()))
        if st is not None:
            skip_ids.add((st.st_dev, st.st_ino))
    base = os.fspath(archive)
    cache = SettingsCache()
    jobs: list[LogJob] = []
    seen: dict[str, str] = {}
    for rel, refused in _walk(base, skip_ids, special):
        path = os.path.join(base, rel)
        ident = log_id(rel)
        if ident in seen and seen[ident] != rel:  # a crafted collision of the short hash
            ident = log_id(rel, digits=64)
        seen[ident] = rel
        name = display_name(rel)
        if refused is not None:
            jobs.append(LogJob(name, path, ident, "", None, entry_error=f"{name}: {refused}"))
            continue
        settings, error = None, None
        try:
            settings = settings_for(archive, Path(path), cache)
        except SettingsError as err:
            error = str(err)
        except (OSError, ValueError) as err:
            error = f"{name}: its logcal.toml files cannot be read ({err})"
        try:
            digest = content_hash(path, special=special)
        except EntryError as err:
            jobs.append(LogJob(name, path, ident, "", None, entry_error=f"{name}: {err}"))
            continue
        except OSError as err:
            jobs.append(
                LogJob(
                    name,
                    path,
                    ident,
                    "",
                    None,
                    entry_error=f"{name}: cannot read it ({err.strerror or err})",
                )
            )
            continue
        jobs.append(LogJob(name, path, ident, digest, settings, error))
    return jobs
