"""Which robot a log comes from: the ``logcal`` metadata record, else inferred from its signals."""

from __future__ import annotations

from logtools.errors import LogcalInputError, NoDriveSignalsError
from logtools.loaded import ResolvedSignals
from logtools.readers import LogData

__all__ = ["METADATA_RECORD", "explain_robot", "infer_robot"]

METADATA_RECORD = "logcal"
"""Name of the MCAP metadata record that carries ``robot`` and the nominal parameters."""


def infer_robot(log: LogData, signals: ResolvedSignals) -> str:
    """The robot type of ``log`` (a plugin's name, see :mod:`logtools.robots`).

    A channel map's ``[robot] type`` wins, then the ``robot`` entry of the ``logcal`` metadata
    record; otherwise the plugins decide from the signals found, in registration order
    (``psi`` -> tractor_trailer, ...).

    Raises:
        LogcalInputError: the metadata names an unknown robot.
        NoDriveSignalsError: neither metadata nor signals tell the robot type.
    """
    return explain_robot(log, signals)[0]


def explain_robot(log: LogData, signals: ResolvedSignals) -> tuple[str, str]:
    """:func:`infer_robot` and why: e.g. ``metadata record 'logcal'`` or ``signal psi``.

    A channel map's ``[robot] type`` comes first (the user says so), then the metadata record,
    then the signals.
    """
    from logtools.robots import UnknownRobotError, identify_robot, plugin_for, plugins

    if signals.robot.type is not None:
        return signals.robot.type, "channel map [robot] type"
    named = log.metadata.get(METADATA_RECORD, {}).get("robot")
    if named is not None:
        try:
            return plugin_for(named).name, f"metadata record {METADATA_RECORD!r}"
        except UnknownRobotError as err:
            raise LogcalInputError(
                f"{log.path}: the {METADATA_RECORD!r} metadata record names robot {named!r}; "
                f"expected one of {', '.join(err.known)}."
            ) from None
    found = identify_robot(frozenset(signals.signals))
    if found is not None:
        return found[0].name, found[1]
    raise NoDriveSignalsError(
        log.path,
        log.topic_names(),
        {p.name: [list(s) for s in p.identifying_signals] for p in plugins()},
    )
