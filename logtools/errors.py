"""Errors raised by logtools. The CLI turns every ``LogcalInputError`` into one message, exit 2."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "ChannelMapEntryError",
    "ChannelMapError",
    "LogFileNotFoundError",
    "LogWriteError",
    "LogcalError",
    "LogcalInputError",
    "MissingSignalsError",
    "NoDriveSignalsError",
    "NotARosbagError",
    "NotAnMcapError",
    "SignalValueError",
    "TimestampError",
    "UnknownEncodingError",
]


class LogcalError(Exception):
    """Root of every error logtools raises on purpose."""


class LogcalInputError(LogcalError):
    """Bad input that the user can fix: the message names file/topic/field and what was expected."""


class LogFileNotFoundError(LogcalInputError):
    def __init__(self, path: str) -> None:
        super().__init__(
            f"{path}: no such file. Expected an MCAP (.mcap) or CSV (.csv) drive log, a rosbag2 "
            "folder (metadata.yaml) or a ROS 1 bag (.bag)."
        )
        self.path = path


class NotAnMcapError(LogcalInputError):
    """A file no format reads; ``formats``: what each registered format is, when the file fits
    none of them (the message names every one)."""

    def __init__(self, path: str, detail: str, formats: Sequence[str] = ()) -> None:
        if formats:
            text = (
                f"{path}: not a log logcal reads ({detail}). Expected one of: "
                + "; ".join(formats)
                + "."
            )
        else:
            text = (
                f"{path}: not a readable MCAP or CSV log ({detail}). Expected an MCAP file "
                "starting with the magic bytes 0x89 'MCAP0', or a CSV with a header row and a "
                "time column 't'."
            )
        super().__init__(text)
        self.path = path


class NotARosbagError(LogcalInputError):
    """A path that looks like a ROS bag (folder with metadata.yaml, .db3, .bag) but is not one."""

    def __init__(self, path: str, detail: str) -> None:
        super().__init__(
            f"{path}: not a readable ROS bag ({detail}). Expected a rosbag2 folder (metadata.yaml "
            "and its .db3 or .mcap files), a rosbag2 .db3 file, or a ROS 1 .bag file."
        )
        self.path, self.detail = path, detail


class UnknownEncodingError(LogcalInputError):
    def __init__(self, path: str, topic: str, encoding: str, known: list[str]) -> None:
        super().__init__(
            f"{path}: topic {topic!r} uses message encoding {encoding!r}, which logcal cannot "
            f"decode. Known encodings: {', '.join(sorted(known))}."
        )
        self.path, self.topic, self.encoding = path, topic, encoding


class MissingSignalsError(LogcalInputError):
    def __init__(self, path: str, missing: list[str], available: list[str], robot: str) -> None:
        have = ", ".join(available) if available else "(no messages)"
        super().__init__(
            f"{path}: the {robot} analysis needs the signals {', '.join(missing)}, which the log "
            f"does not hold. Topics in the log: {have}. Map them with --channel-map FILE.toml "
            "(see LOG_FORMAT in the README)."
        )
        self.path, self.missing, self.available = path, missing, available


class SignalValueError(LogcalInputError):
    """NaN/inf where not allowed, angles that look like degrees, and similar value problems."""


class TimestampError(LogcalInputError):
    """Timestamps that cannot be put on one time base."""


class ChannelMapError(LogcalInputError):
    """A channel-map TOML that is malformed or names a topic/field the log does not have."""


class ChannelMapEntryError(ChannelMapError):
    """One key of a channel-map TOML is wrong: the message names the file and the key.

    Attributes:
        file: the channel-map file ("" for a map built in code).
        key: the dotted key, e.g. ``signals.psi.unit``.
        detail: what is wrong and what is expected.
    """

    def __init__(self, file: str, key: str, detail: str) -> None:
        where = f"{file}: " if file else "channel map: "
        super().__init__(f"{where}[{key}] {detail}")
        self.file, self.key, self.detail = file, key, detail


class NoDriveSignalsError(MissingSignalsError):
    """A log with none of the drive signals from which logcal tells the robot type."""

    def __init__(
        self,
        path: str,
        available: list[str],
        expected: dict[str, list[list[str]]] | None = None,
    ) -> None:
        """``expected``: each robot type's sets of signals, any one of which identifies it (from
        the robot plugins)."""
        have = ", ".join(available) if available else "(none)"
        expected = {robot: [s for s in sets if s] for robot, sets in (expected or {}).items()}
        options = "; ".join(
            f"{' or '.join(', '.join(s) for s in sets)} ({robot})"
            for robot, sets in expected.items()
            if sets
        )
        LogcalInputError.__init__(
            self,
            f"{path}: no drive signals found, so the robot type is unknown. Expected a 'logcal' "
            f"metadata record or the signals of one robot: {options or '(no robot plugins)'}. "
            f"Topics in the log: {have}. Map yours with --channel-map FILE.toml (LOG_FORMAT.md "
            "lists the default topics).",
        )
        self.path, self.available = path, available
        self.missing = sorted({s for sets in expected.values() for sig in sets for s in sig})


class LogWriteError(LogcalInputError):
    """A log that cannot be written: unwritable path, or frames lacking a field to write."""
