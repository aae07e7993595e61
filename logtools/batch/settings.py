"""``logcal.toml``: per-folder settings of a log archive (robot type, channel map, robot id, and
every registered robot's own options).

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
    urdf = "arm.urdf"           # a robot option (here the manipulator's): any key a registered
    cutoff_hz = 8.0             # plugin declares (logtools.robot_options.option_specs)
    start = 5.0                 # analyse each log from 5 s to 60 s after its first sample
    end = 60.0                  # (as `logcal analyze --start/--end`; `batch --start/--end` wins)

The accepted keys are :data:`BASE_KEYS`, :data:`SPAN_KEYS` plus the option keys of every
registered robot plugin, read from the plugins' declarations (nothing robot-specific is written
here). Each option value
is checked by :func:`~logtools.robot_options.build_options` with ``source="settings"`` and the
``logcal.toml`` path as ``where``; a key several robots declare is checked against each.

Every key is optional. A malformed file, an unknown key or a bad value makes every log below it
fail with one message naming the file and key (the rest of the batch still runs).

A settings file is data, never an instruction to read elsewhere: ``channel_map`` and any option
declared to name a file (``option(..., file=True)`` or of type ``Path``; the manipulator's
``urdf``, also declared ``or_name=True``, is a file unless it is a plain model name) may name
only regular files inside the archive (relative to the ``logcal.toml``; absolute paths, ``~``
and ``..`` leading out of the archive are refused with the reason), no text is globbed, and
``logcal.toml`` itself must be a regular file (not a link, at most 1 MiB).
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import stat
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from logtools import toml_bounded
from logtools.batch.files import SETTINGS_MAX_BYTES, open_regular, read_regular
from logtools.errors import LogcalInputError

if TYPE_CHECKING:
    from logtools.robot_options import OptionSpec, RobotOptions

__all__ = [
    "ARCHIVE_ROOT_ID",
    "BASE_KEYS",
    "SETTINGS_FILE",
    "SETTINGS_MAX_BYTES",
    "SPAN_KEYS",
    "LogSettings",
    "SettingsCache",
    "SettingsError",
    "accepted_keys",
    "open_regular",
    "read_regular",
    "settings_for",
]

SETTINGS_FILE = "logcal.toml"
ARCHIVE_ROOT_ID = "(archive root)"
BASE_KEYS = ("robot", "channel_map", "robot_id")
"""The keys of the batch itself; every other accepted key (but :data:`SPAN_KEYS`) is a registered
robot's option."""
SPAN_KEYS = ("start", "end")
"""Seconds from each log's first sample to crop it to (``logcal analyze --start/--end``)."""


class SettingsError(LogcalInputError):
    """A ``logcal.toml`` that cannot be used: the message names the file and the key."""

    def __init__(
        self, file: Path, key: str | None, detail: str, *, message: str | None = None
    ) -> None:
        where = f"{file}: [{key}] " if key else f"{file}: "
        super().__init__(message if message is not None else where + detail)
        self.file, self.key, self.detail = file, key, detail


@dataclass(frozen=True)
class LogSettings:
    """The settings that apply to one log.

    Attributes:
        robot: robot type named by a ``logcal.toml`` (None: from the log).
        channel_map: absolute path of the channel-map file (None: defaults).
        robot_id: the physical robot the log belongs to.
        sources: the ``logcal.toml`` files that applied, root first.
        fingerprint: sha256 of the settings (options included) and of the content of the files
            they name, so that a changed channel map or URDF redoes the logs it applies to.
        robot_from: the file that set ``robot`` (None: none did).
        options: the robots' options set by the files, by settings key, as checked plain values
            (numbers, text, true/false; a file an option names as its absolute path): what a
            worker turns into typed options with
            :func:`~logtools.analyze.options_from_settings`.
        robot_options: the same, typed: by plugin name, that plugin's options instance (robots
            given no key left out), as ``AnalysisConfig(robot_options=...)`` takes them.
        start_s, end_s: the ``start``/``end`` keys: the span of each log to analyse, in seconds
            from its first sample (None: from the first, to the last sample).
    """

    robot: str | None
    channel_map: str | None
    robot_id: str
    sources: tuple[str, ...]
    fingerprint: str
    robot_from: str | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    robot_options: Mapping[str, RobotOptions] = field(default_factory=dict)
    start_s: float | None = None
    end_s: float | None = None


_MODEL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,63}")


@dataclass(frozen=True)
class _Declared:
    """One robot's declaration of an option: the spec and the robot's options class."""

    spec: OptionSpec
    cls: type[RobotOptions]


def _option_specs() -> dict[str, list[_Declared]]:
    """Settings key -> the option of every registered robot that declares it (registry
    order)."""
    from logtools.robot_options import option_specs
    from logtools.robots import plugins

    out: dict[str, list[_Declared]] = {}
    for plugin in plugins():
        for spec in option_specs(plugin):
            out.setdefault(spec.key, []).append(_Declared(spec, plugin.options))
    return out


def accepted_keys() -> tuple[str, ...]:
    """Every key a ``logcal.toml`` may hold: :data:`BASE_KEYS`, then each registered robot's
    option keys (in registry and field order)."""
    return (*BASE_KEYS, *SPAN_KEYS, *(k for k in _option_specs() if k not in BASE_KEYS + SPAN_KEYS))


def _names_file(spec: OptionSpec, value: str) -> bool:
    """Whether ``value`` of the option ``spec`` names a file, by the option's declaration
    (``file=True`` or type ``Path``; never by how its flag or metavar is spelled): always,
    unless it is declared ``or_name=True`` and ``value`` is a plain name (``panda``)."""
    if not spec.file:
        return False
    return not spec.or_name or _MODEL_NAME.fullmatch(value) is None


class SettingsCache:
    """What :func:`settings_for` has read during one walk: each folder's parsed ``logcal.toml``
    and settings, and the registered robots' option declarations (read once)."""

    def __init__(self) -> None:
        self.files: dict[Path, dict[str, Any]] = {}
        self.folders: dict[Path, LogSettings] = {}
        self._specs: dict[str, list[_Declared]] | None = None

    @property
    def specs(self) -> dict[str, list[_Declared]]:
        """Settings key -> every registered robot's declaration of it."""
        if self._specs is None:
            self._specs = _option_specs()
        return self._specs


def _inside(archive: Path, file: Path, key: str, value: str) -> Path:
    """The file ``value`` names, relative to ``file``'s folder, if it is a regular file inside
    ``archive`` (links inside the archive allowed when their target is inside it too)."""
    if "\0" in value:
        raise SettingsError(file, key, f"names {value!r}, which holds a NUL character.")
    if Path(value).is_absolute() or value.startswith("~"):
        raise SettingsError(
            file,
            key,
            f"names {value!r}, an absolute path; a logcal.toml may "
            "name only files inside the archive, relative to itself.",
        )
    path = (file.parent / value).resolve()
    if archive not in path.parents:
        raise SettingsError(
            file,
            key,
            f"names {value!r}, which is outside the archive "
            f"{archive}; a logcal.toml may name only files inside "
            "the archive.",
        )
    try:
        st = os.stat(path)
    except OSError as err:
        raise SettingsError(
            file,
            key,
            f"names {value!r}, which is not a file (looked for {path}: {err.strerror or err}).",
        ) from err
    if not stat.S_ISREG(st.st_mode):
        raise SettingsError(
            file, key, f"names {value!r}, which is not a regular file (looked for {path})."
        )
    return path


def _plain(value: Any) -> Any:
    """A checked option value as plain data (an Enum as its value, a path as text)."""
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, Path):
        return str(value)
    return value


def _option_value(
    archive: Path, file: Path, key: str, value: Any, declared: list[_Declared]
) -> Any:
    """``value`` of the robot option ``key`` checked against every robot declaring it
    (``build_options``), a file it names resolved inside the archive; as plain data."""
    from logtools.robot_options import build_options

    checked: Any = None
    for d in declared:
        try:
            built = build_options(d.cls, {key: value}, source="settings", where=str(file))
        except LogcalInputError as err:
            raise SettingsError(file, key, str(err), message=str(err)) from err
        if checked is None:
            checked = _plain(getattr(built, key))
    if isinstance(checked, str) and _names_a_file(declared, checked):
        checked = str(_inside(archive, file, key, checked))
    return checked


def _names_a_file(declared: list[_Declared], value: str) -> bool:
    return any(_names_file(d.spec, value) for d in declared)


def _typed(
    options: Mapping[str, Any], specs: Mapping[str, list[_Declared]], where: str
) -> dict[str, RobotOptions]:
    """By robot, its options instance from the checked ``options`` (each key to every robot
    declaring it, as :func:`~logtools.analyze.options_from_settings` does)."""
    from logtools.robot_options import build_options

    values: dict[type[RobotOptions], dict[str, Any]] = {}
    names: dict[type[RobotOptions], str] = {}
    for key, value in options.items():
        for d in specs.get(key, []):
            values.setdefault(d.cls, {})[key] = value
            names[d.cls] = d.spec.robot
    return {
        names[cls]: build_options(cls, v, source="settings", where=where)
        for cls, v in values.items()
    }


def _read(archive: Path, file: Path, specs: Mapping[str, list[_Declared]]) -> dict[str, Any]:
    try:
        text = read_regular(file).decode("utf-8")
        doc = toml_bounded.loads(text)
    except (
        OSError,
        UnicodeDecodeError,
        tomllib.TOMLDecodeError,
        toml_bounded.TomlTooDeepError,
    ) as err:
        raise SettingsError(file, None, f"not a readable TOML file ({err}).") from err
    out: dict[str, Any] = {}
    for key, value in doc.items():
        if key in BASE_KEYS:
            if not isinstance(value, str) or not value.strip():
                raise SettingsError(file, key, f"is {value!r}; expected a non-empty string.")
            out[key] = str(_inside(archive, file, key, value)) if key == "channel_map" else value
        elif key in SPAN_KEYS:
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not math.isfinite(value)
                or value < 0
            ):
                raise SettingsError(
                    file, key, f"is {value!r}; expected seconds >= 0 from each log's first sample."
                )
            out[key] = float(value)
        elif key in specs:
            out[key] = _option_value(archive, file, key, value, specs[key])
        else:
            known = (*BASE_KEYS, *SPAN_KEYS, *(k for k in specs if k not in BASE_KEYS + SPAN_KEYS))
            raise SettingsError(
                file, key, f"is not a logcal.toml key; expected one of {', '.join(known)}."
            )
    return out


def _file_digest(path: str) -> str:
    try:
        return hashlib.sha256(read_regular(path, limit=64 * SETTINGS_MAX_BYTES)).hexdigest()
    except OSError:
        return "unreadable"


def settings_for(archive: Path, log: Path, cache: SettingsCache | None = None) -> LogSettings:
    """The settings of ``log`` (a path inside ``archive``) from the ``logcal.toml`` files on the
    way from ``archive`` down to the log's folder.

    ``cache`` (one per walk) avoids reading a file, or working out a folder's settings, once
    per log.

    Raises:
        SettingsError: a ``logcal.toml`` on the way is malformed, has an unknown key or a bad
            value, or names a missing file.
    """
    cache = SettingsCache() if cache is None else cache
    root = archive.resolve()  # files named by a logcal.toml must resolve inside it
    rel = log.relative_to(archive)
    folders = [archive]
    for part in rel.parts[:-1]:
        folders.append(folders[-1] / part)
    if folders[-1] in cache.folders:  # the logs of one folder share its settings
        return cache.folders[folders[-1]]
    merged: dict[str, Any] = {}
    sources: list[str] = []
    robot_from = None
    for folder in folders:
        file = folder / SETTINGS_FILE
        present = os.path.lexists(file)  # a link or FIFO named logcal.toml: refused by _read
        if folder not in cache.files:
            cache.files[folder] = _read(root, file, cache.specs) if present else {}
        if present:
            sources.append(str(file))
        merged.update(cache.files[folder])
        if "robot" in cache.files[folder]:
            robot_from = str(file)
    default_id = rel.parts[0] if len(rel.parts) > 1 else ARCHIVE_ROOT_ID
    options = {k: v for k, v in sorted(merged.items()) if k not in BASE_KEYS + SPAN_KEYS}
    start, end = merged.get("start"), merged.get("end")
    if start is not None and end is not None and end <= start:
        raise SettingsError(
            Path(sources[-1]),
            "end",
            f"is {end:g} s, not after start = "
            f"{start:g} s (the logcal.toml files "
            f"{', '.join(sources)}).",
        )
    digest = hashlib.sha256()
    for key in BASE_KEYS:
        digest.update(f"{key}={merged.get(key, '')}\n".encode())
    for key in SPAN_KEYS:  # only when set: a settings file without them keeps its key
        if key in merged:
            digest.update(f"{key}={merged[key]!r}\n".encode())
    for key, value in options.items():
        digest.update(f"{key}={type(value).__name__}:{value}\n".encode())
    named = [merged["channel_map"]] if "channel_map" in merged else []
    named += [
        v
        for k, v in options.items()
        if isinstance(v, str) and _names_a_file(cache.specs.get(k, []), v)
    ]
    for path in named:
        digest.update(_file_digest(path).encode())
    typed = _typed(options, cache.specs, sources[-1] if sources else SETTINGS_FILE)
    settings = LogSettings(
        robot=merged.get("robot"),
        channel_map=merged.get("channel_map"),
        robot_id=merged.get("robot_id", default_id),
        sources=tuple(sources),
        fingerprint=digest.hexdigest(),
        robot_from=robot_from,
        options=options,
        robot_options=typed,
        start_s=start,
        end_s=end,
    )
    cache.folders[folders[-1]] = settings
    return settings
