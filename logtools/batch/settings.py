"""``logcal.toml``: per-folder settings of a log archive (robot type, channel map, robot id).

A ``logcal.toml`` may sit in the archive's root or in any folder below it; it applies to the logs
of its folder and of every folder below. Where several apply, the nearest one (deepest folder)
wins key by key::

    # logcal.toml
    robot = "tractor_trailer"   # robot type (a plugin's name); default: the log's metadata
                                # record, else its signals (as `logcal analyze`)
    channel_map = "map.toml"    # a channel-map TOML (docs/LOG_FORMAT.md), relative to this file
    robot_id = "truck-07"       # the physical robot that recorded these logs: logs are pooled
                                # and followed over time per robot_id; default: the log's
                                # top-level folder ("(archive root)" for logs at the root)
    urdf = "arm.urdf"           # an arm's URDF (relative to this file) or example-robot-data name

Every key is optional. A malformed file, or an unknown key, makes every log below it fail with
one message naming the file and key (the rest of the batch still runs).

A settings file is data, never an instruction to read elsewhere: ``channel_map`` and ``urdf``
may name only regular files inside the archive (relative to the ``logcal.toml``; absolute
paths, ``~`` and ``..`` leading out of the archive are refused with the reason), no text is
globbed, and ``logcal.toml`` itself must be a regular file (not a link, at most 1 MiB).
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import stat
import tomllib
from dataclasses import dataclass
from pathlib import Path

from logtools.errors import LogcalInputError

__all__ = ["ARCHIVE_ROOT_ID", "SETTINGS_FILE", "SETTINGS_MAX_BYTES", "LogSettings",
           "SettingsError", "open_regular", "read_regular", "settings_for"]

SETTINGS_FILE = "logcal.toml"
ARCHIVE_ROOT_ID = "(archive root)"
_KEYS = ("robot", "channel_map", "robot_id", "urdf")


class SettingsError(LogcalInputError):
    """A ``logcal.toml`` that cannot be used: the message names the file and the key."""

    def __init__(self, file: Path, key: str | None, detail: str) -> None:
        where = f"{file}: [{key}] " if key else f"{file}: "
        super().__init__(where + detail)
        self.file, self.key, self.detail = file, key, detail


@dataclass(frozen=True)
class LogSettings:
    """The settings that apply to one log.

    Attributes:
        robot: robot type named by a ``logcal.toml`` (None: from the log).
        channel_map: absolute path of the channel-map file (None: defaults).
        robot_id: the physical robot the log belongs to.
        urdf: an arm's URDF path (absolute) or model name (None: none).
        sources: the ``logcal.toml`` files that applied, root first.
        robot_from: the file that set ``robot`` (None: none did).
        fingerprint: sha256 of the settings and of the content of the files they name, so that
            a changed channel map redoes the logs it applies to.
    """

    robot: str | None
    channel_map: str | None
    robot_id: str
    urdf: str | None
    sources: tuple[str, ...]
    fingerprint: str
    robot_from: str | None = None


SETTINGS_MAX_BYTES = 1 << 20
"""A ``logcal.toml``, channel map or URDF larger than this is refused (1 MiB)."""
_MODEL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,63}")


def open_regular(path: str | Path, *, special: set[int] | None = None) -> int:
    """A read-only file descriptor of ``path`` if it is a regular file and not a link.

    Opened with ``O_NOFOLLOW | O_NONBLOCK`` (a link is refused, a FIFO does not block the
    open), then checked with ``fstat``: a FIFO, socket or device is closed unread, and so is a
    file on a kernel file system whose device is in ``special``.

    Raises:
        OSError: it cannot be opened, or is not a regular file (``EINVAL``, with its kind).
    """
    from logtools.batch.archive import file_kind

    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    fd = os.open(path, flags)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, f"it is {file_kind(st.st_mode)}; logcal reads "
                                        "regular files only")
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


def _inside(archive: Path, file: Path, key: str, value: str) -> Path:
    """The file ``value`` names, relative to ``file``'s folder, if it is a regular file inside
    ``archive`` (links inside the archive allowed when their target is inside it too)."""
    if "\0" in value:
        raise SettingsError(file, key, f"names {value!r}, which holds a NUL character.")
    if Path(value).is_absolute() or value.startswith("~"):
        raise SettingsError(file, key, f"names {value!r}, an absolute path; a logcal.toml may "
                                       "name only files inside the archive, relative to itself.")
    path = (file.parent / value).resolve()
    if archive not in path.parents:
        raise SettingsError(file, key, f"names {value!r}, which is outside the archive "
                                       f"{archive}; a logcal.toml may name only files inside "
                                       "the archive.")
    try:
        st = os.stat(path)
    except OSError as err:
        raise SettingsError(file, key, f"names {value!r}, which is not a file "
                                       f"(looked for {path}: {err.strerror or err}).") from err
    if not stat.S_ISREG(st.st_mode):
        raise SettingsError(file, key, f"names {value!r}, which is not a regular file "
                                       f"(looked for {path}).")
    return path


def _read(archive: Path, file: Path) -> dict[str, str]:
    try:
        text = read_regular(file).decode("utf-8")
        doc = tomllib.loads(text)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise SettingsError(file, None, f"not a readable TOML file ({err}).") from err
    out: dict[str, str] = {}
    for key, value in doc.items():
        if key not in _KEYS:
            raise SettingsError(file, key, f"is not a logcal.toml key; expected one of "
                                           f"{', '.join(_KEYS)}.")
        if not isinstance(value, str) or not value.strip():
            raise SettingsError(file, key, f"is {value!r}; expected a non-empty string.")
        if key in ("channel_map", "urdf") and (key == "channel_map" or _looks_like_path(value)):
            value = str(_inside(archive, file, key, value))
        out[key] = value
    return out


def _looks_like_path(value: str) -> bool:
    """A ``urdf`` value that is not a plain model name (``panda``, ``ur5``) is a path."""
    return _MODEL_NAME.fullmatch(value) is None


def _file_digest(path: str) -> str:
    try:
        return hashlib.sha256(read_regular(path, limit=64 * SETTINGS_MAX_BYTES)).hexdigest()
    except OSError:
        return "unreadable"


def settings_for(archive: Path, log: Path, cache: dict[Path, dict[str, str]] | None = None
                 ) -> LogSettings:
    """The settings of ``log`` (a path inside ``archive``) from the ``logcal.toml`` files on the
    way from ``archive`` down to the log's folder.

    ``cache`` (folder -> parsed file) avoids reading a file once per log.

    Raises:
        SettingsError: a ``logcal.toml`` on the way is malformed or names a missing file.
    """
    cache = {} if cache is None else cache
    root = archive.resolve()  # files named by a logcal.toml must resolve inside it
    rel = log.relative_to(archive)
    folders = [archive]
    for part in rel.parts[:-1]:
        folders.append(folders[-1] / part)
    merged: dict[str, str] = {}
    sources: list[str] = []
    robot_from = None
    for folder in folders:
        file = folder / SETTINGS_FILE
        present = os.path.lexists(file)  # a link or FIFO named logcal.toml: refused by _read
        if folder not in cache:
            cache[folder] = _read(root, file) if present else {}
        if present:
            sources.append(str(file))
        merged.update(cache[folder])
        if "robot" in cache[folder]:
            robot_from = str(file)
    default_id = rel.parts[0] if len(rel.parts) > 1 else ARCHIVE_ROOT_ID
    digest = hashlib.sha256()
    for key in _KEYS:
        digest.update(f"{key}={merged.get(key, '')}\n".encode())
    for key in ("channel_map", "urdf"):
        if key in merged and _looks_like_path(merged[key]):
            digest.update(_file_digest(merged[key]).encode())
    return LogSettings(
        robot=merged.get("robot"),
        channel_map=merged.get("channel_map"),
        robot_id=merged.get("robot_id", default_id),
        urdf=merged.get("urdf"),
        sources=tuple(sources),
        fingerprint=digest.hexdigest(),
        robot_from=robot_from,
    )
