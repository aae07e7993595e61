"""Errors raised by logtools. The CLI turns every ``LogcalInputError`` into one message, exit 2."""

from __future__ import annotations

__all__ = [
    "ChannelMapError",
    "LogFileNotFoundError",
    "LogWriteError",
    "LogcalError",
    "LogcalInputError",
    "MissingSignalsError",
    "NoDriveSignalsError",
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
        super().__init__(f"{path}: no such file. Expected an MCAP (.mcap) or CSV (.csv) drive log.")
        self.path = path


class NotAnMcapError(LogcalInputError):
    def __init__(self, path: str, detail: str) -> None:
        super().__init__(
            f"{path}: not a readable MCAP or CSV log ({detail}). Expected an MCAP file starting "
            "with the magic bytes 0x89 'MCAP0', or a CSV with a header row and a time column 't'."
        )
        self.path = path


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


class NoDriveSignalsError(MissingSignalsError):
    """A log with none of the drive signals from which logcal tells the robot type."""

    def __init__(self, path: str, available: list[str]) -> None:
        have = ", ".join(available) if available else "(none)"
        LogcalInputError.__init__(
            self,
            f"{path}: no drive signals found, so the robot type is unknown. Expected a 'logcal' "
            "metadata record or one of: psi (/hitch/angle, tractor_trailer), wheel_left and "
            "wheel_right (/wheels, diff_drive), q (/joint_states, manipulator_2link). "
            f"Topics in the log: {have}. Map yours with --channel-map FILE.toml.",
        )
        self.path, self.available = path, available
        self.missing = ["psi", "wheel_left", "wheel_right", "q"]


class LogWriteError(LogcalInputError):
    """A log that cannot be written: unwritable path, or frames lacking a field to write."""
