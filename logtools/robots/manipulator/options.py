"""The arm's own options (``logcal analyze``/``view`` flags, settings keys)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from logtools.robot_options import RobotOptions, option

__all__ = ["EffortSide", "ManipulatorOptions"]


class EffortSide(Enum):
    """Which side of each joint's transmission the logged effort is on."""

    JOINT = "joint"
    ACTUATOR = "actuator"


@dataclass(frozen=True)
class ManipulatorOptions(RobotOptions):
    """Options of an arm analysis (None: not given, the analysis' default).

    Attributes:
        urdf: the arm's URDF file or an example-robot-data model name (else the channel map's
            ``[robot] urdf`` or the log's metadata).
        cutoff_hz: zero-phase low-pass cut-off for q, q', q'' and torque (Hz; default 10).
        effort: ``joint`` (default): the logged effort is the joint's torque (force); ``actuator``:
            it is the actuator's, and each joint's is multiplied by its URDF transmission's
            mechanical reduction (and by its torque constant, the channel map's ``[robot]
            torque_constant_<joint>``, when given).
    """

    urdf: str | None = option(
        flag="--urdf",
        metavar="PATH_OR_NAME",
        view=True,
        info=True,
        file=True,
        or_name=True,
        help="An arm's URDF file, or a model name of example-robot-data (e.g. panda).",
    )
    cutoff_hz: float | None = option(
        flag="--cutoff-hz",
        metavar="HZ",
        above=0.0,
        help="An arm's zero-phase low-pass cut-off for q, q', q'' and torque (Hz; default 10).",
    )
    effort: EffortSide | None = option(  # noqa: RUF009  (option() is a dataclasses.field)
        flag="--effort",
        view=True,
        help="An arm's logged effort is joint-side (default) or actuator-side: then each joint's "
        "is multiplied by its URDF transmission's mechanical reduction (and the channel map's "
        "[robot] torque_constant_<joint>, if given).",
    )
