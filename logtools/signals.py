"""Logical signals and the default topic/field mapping of LOG_FORMAT.md."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

__all__ = [
    "DEFAULT_JSON_MAP",
    "DEFAULT_ROS2_MAP",
    "ROBOT_REQUIRED_SIGNALS",
    "SIGNAL_UNITS",
    "Robot",
    "SignalSource",
]


class Robot(StrEnum):
    TRACTOR_TRAILER = "tractor_trailer"
    DIFF_DRIVE = "diff_drive"
    MANIPULATOR_2LINK = "manipulator_2link"


SIGNAL_UNITS: dict[str, str] = {
    "kappa_cmd": "1/m",
    "v": "m/s",
    "omega": "rad/s",
    "x": "m",
    "y": "m",
    "yaw": "rad",
    "psi": "rad",
    "wheel_left": "rad",
    "wheel_right": "rad",
    "v_cmd": "m/s",
    "omega_cmd": "rad/s",
    "kappa": "1/m",
}

ROBOT_REQUIRED_SIGNALS: dict[Robot, tuple[str, ...]] = {
    Robot.TRACTOR_TRAILER: ("psi",),  # plus kappa, derived from (omega, v) or (x, y)
    Robot.DIFF_DRIVE: ("wheel_left", "wheel_right"),
    Robot.MANIPULATOR_2LINK: ("q", "tau"),
}


@dataclass(frozen=True)
class SignalSource:
    """Where a logical signal comes from: a topic and a flattened field path."""

    topic: str
    field: str
    transform: str | None = None  # e.g. "yaw_from_quaternion"


# Default mapping for the JSON encoding that `logcal simulate` writes.
DEFAULT_JSON_MAP: dict[str, SignalSource] = {
    "kappa_cmd": SignalSource("/cmd/curvature", "curvature"),
    "v_cmd": SignalSource("/cmd/vel", "v"),
    "omega_cmd": SignalSource("/cmd/vel", "omega"),
    "v": SignalSource("/odom", "v"),
    "omega": SignalSource("/odom", "omega"),
    "x": SignalSource("/pose", "x"),
    "y": SignalSource("/pose", "y"),
    "yaw": SignalSource("/pose", "yaw"),
    "psi": SignalSource("/hitch/angle", "angle"),
    "wheel_left": SignalSource("/wheels", "left"),
    "wheel_right": SignalSource("/wheels", "right"),
}

# Default mapping for ROS 2 standard types (field paths flattened with dots).
DEFAULT_ROS2_MAP: dict[str, SignalSource] = {
    "kappa_cmd": SignalSource("/cmd/curvature", "data"),
    "v_cmd": SignalSource("/cmd/vel", "linear.x"),
    "omega_cmd": SignalSource("/cmd/vel", "angular.z"),
    "v": SignalSource("/odom", "twist.twist.linear.x"),
    "omega": SignalSource("/odom", "twist.twist.angular.z"),
    "x": SignalSource("/pose", "pose.pose.position.x"),
    "y": SignalSource("/pose", "pose.pose.position.y"),
    "yaw": SignalSource("/pose", "pose.pose.orientation", transform="yaw_from_quaternion"),
    "psi": SignalSource("/hitch/angle", "data"),
    "wheel_left": SignalSource("/wheels", "position.0"),
    "wheel_right": SignalSource("/wheels", "position.1"),
}
