"""Which robot a log comes from: the ``logcal`` metadata record, else inferred from its signals."""

from __future__ import annotations

from logtools.channel_map import ResolvedSignals
from logtools.errors import LogcalInputError, NoDriveSignalsError
from logtools.readers import LogData
from logtools.signals import Robot

__all__ = ["METADATA_RECORD", "explain_robot", "infer_robot"]

METADATA_RECORD = "logcal"
"""Name of the MCAP metadata record that carries ``robot`` and the nominal parameters."""


def infer_robot(log: LogData, signals: ResolvedSignals) -> Robot:
    """The robot type of ``log``.

    A channel map's ``[robot] type`` wins, then the ``robot`` entry of the ``logcal`` metadata
    record; otherwise the signals decide:
    ``psi`` -> tractor_trailer, ``wheel_left`` and ``wheel_right`` -> diff_drive, joint signals
    (``q1``, …) -> manipulator_2link.

    Raises:
        LogcalInputError: the metadata names an unknown robot.
        NoDriveSignalsError: neither metadata nor signals tell the robot type.
    """
    return explain_robot(log, signals)[0]


def explain_robot(log: LogData, signals: ResolvedSignals) -> tuple[Robot, str]:
    """:func:`infer_robot` and why: e.g. ``metadata record 'logcal'`` or ``signal psi``.

    A channel map's ``[robot] type`` comes first (the user says so), then the metadata record,
    then the signals.
    """
    if signals.robot.type is not None:
        return signals.robot.type, "channel map [robot] type"
    named = log.metadata.get(METADATA_RECORD, {}).get("robot")
    if named is not None:
        try:
            return Robot(named), f"metadata record {METADATA_RECORD!r}"
        except ValueError:
            raise LogcalInputError(
                f"{log.path}: the {METADATA_RECORD!r} metadata record names robot {named!r}; "
                f"expected one of {', '.join(r.value for r in Robot)}."
            ) from None
    found = signals.signals
    if "psi" in found:
        return Robot.TRACTOR_TRAILER, "signal psi"
    if "wheel_left" in found and "wheel_right" in found:
        return Robot.DIFF_DRIVE, "signals wheel_left, wheel_right"
    joints = sorted(n for n in found if n.startswith(("q", "tau")) and n[-1].isdigit())
    if joints:
        return Robot.MANIPULATOR_2LINK, f"signals {', '.join(joints)}"
    raise NoDriveSignalsError(log.path, log.topic_names())
