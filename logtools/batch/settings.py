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
"""

from __future__ import annotations

import hashlib
import tomllib
from dataclasses import dataclass
from pathlib import Path

from logtools.errors import LogcalInputError

__all__ = ["ARCHIVE_ROOT_ID", "SETTINGS_FILE", "LogSettings", "SettingsError", "settings_for"]

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


def _read(file: Path) -> dict[str, str]:
    try:
        doc = tomllib.loads(file.read_text(encoding="utf-8"))
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
            path = (file.parent / value).resolve()
            if not path.is_file():
                raise SettingsError(file, key, f"names {value!r}, which is not a file "
                                               f"(looked for {path}).")
            value = str(path)
        out[key] = value
    return out


def _looks_like_path(value: str) -> bool:
    return "/" in value or value.endswith((".urdf", ".xml"))


def _file_digest(path: str) -> str:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
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
    rel = log.relative_to(archive)
    folders = [archive]
    for part in rel.parts[:-1]:
        folders.append(folders[-1] / part)
    merged: dict[str, str] = {}
    sources: list[str] = []
    robot_from = None
    for folder in folders:
        file = folder / SETTINGS_FILE
        if folder not in cache:
            cache[folder] = _read(file) if file.is_file() else {}
        if file.is_file():
            sources.append(str(file))
        merged.update(cache[folder])
        if "robot" in cache[folder]:
            robot_from = str(file)
    default_id = rel.parts[0] if len(rel.parts) > 1 else ARCHIVE_ROOT_ID
    digest = hashlib.sha256()
    for key in _KEYS:
        digest.update(f"{key}={merged.get(key, '')}\n".encode())
    for key in ("channel_map", "urdf"):
        if key in merged and Path(merged[key]).is_file():
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
