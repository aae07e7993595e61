"""Write a simulated differential-drive run (:class:`calib.diff_drive.sim.DiffDriveSim`) as an
MCAP (JSON or ROS 2) or CSV log per LOG_FORMAT.md: ``/wheels`` (left, right: cumulative wheel
angles, rad), ``/cmd/vel`` (v, omega), ``/pose`` (ground truth x, y, yaw) and, with a gyro,
``/odom`` (omega: the gyro's yaw rate; v: the nominal odometry speed).

``style="turtlebot"`` writes instead what a TurtleBot records: ``/joint_states``
(``sensor_msgs/JointState`` with joints ``wheel_left_joint``, ``wheel_right_joint``),
``/cmd_vel`` and the ground truth on ``/pose``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Literal

import numpy as np
import polars as pl

from calib.diff_drive.sim import DiffDriveSim
from logtools.errors import LogWriteError
from logtools.writers.csv_writer import write_frames_csv
from logtools.writers.encoding import Encoding
from logtools.writers.mcap_writer import (
    POSE_ODOMETRY_ROS2,
    CdrEncoder,
    JsonEncoder,
    TopicBinding,
    write_frames_mcap,
)

__all__ = ["JSON_BINDINGS", "Style", "run_frames", "run_metadata", "write_run"]

Style = Literal["logcal", "turtlebot"]

JSON_BINDINGS: tuple[TopicBinding, ...] = (
    TopicBinding(
        "/wheels", "wheels", "logcal/Wheels", {"left": "wheel_left", "right": "wheel_right"}
    ),
    TopicBinding("/cmd/vel", "cmd", "logcal/VelocityCommand", {"v": "v_cmd", "omega": "omega_cmd"}),
    TopicBinding("/pose", "pose", "logcal/Pose2D", {"x": "x", "y": "y", "yaw": "yaw"}),
)
_GYRO_JSON = TopicBinding("/odom", "odom", "logcal/Odometry", {"v": "v", "omega": "omega"})
_JOINTS = ["wheel_left_joint", "wheel_right_joint"]
_TURTLE_JSON: tuple[TopicBinding, ...] = (
    TopicBinding(
        "/joint_states",
        "wheels",
        "sensor_msgs/JointState",
        {"position.0": "wheel_left", "position.1": "wheel_right"},
        constants={"name": _JOINTS},
    ),
    TopicBinding(
        "/cmd_vel", "cmd", "geometry_msgs/Twist", {"linear.x": "v_cmd", "angular.z": "omega_cmd"}
    ),
    TopicBinding("/pose", "pose", "logcal/Pose2D", {"x": "x", "y": "y", "yaw": "yaw"}),
)

_POSE_ROS2 = POSE_ODOMETRY_ROS2
_TWIST = {"linear.x": "v_cmd", "angular.z": "omega_cmd"}
_ODOM_ROS2 = TopicBinding(
    "/odom",
    "odom",
    "nav_msgs/msg/Odometry",
    {"twist.twist.linear.x": "v", "twist.twist.angular.z": "omega"},
    constants={"header.frame_id": "odom", "child_frame_id": "base_link"},
    stamp_field="header.stamp",
)

CSV_COLUMNS: dict[str, tuple[str, ...]] = {
    "wheels": ("wheel_left", "wheel_right"),
    "cmd": ("v_cmd", "omega_cmd"),
    "pose": ("x", "y", "yaw"),
}


def run_frames(sim: DiffDriveSim) -> dict[str, pl.DataFrame]:
    """Sensor groups of ``sim``: wheels, cmd, pose (with the yaw quaternion), odom (gyro)."""
    t_ns = np.round(sim.t * 1e9).astype(np.int64)
    nom = sim.config.nominal
    dt = np.gradient(sim.t)
    v = 0.5 * (nom.r_R * np.gradient(sim.wheel_right) + nom.r_L * np.gradient(sim.wheel_left)) / dt
    return {
        "wheels": pl.DataFrame(
            {"t_ns": t_ns, "wheel_left": sim.wheel_left, "wheel_right": sim.wheel_right}
        ),
        "cmd": pl.DataFrame(
            {"t_ns": t_ns, "v_cmd": sim.commands.v_cmd, "omega_cmd": sim.commands.omega_cmd}
        ),
        "pose": pl.DataFrame(
            {
                "t_ns": t_ns,
                "x": sim.x,
                "y": sim.y,
                "yaw": sim.yaw,
                "qz": np.sin(sim.yaw / 2),
                "qw": np.cos(sim.yaw / 2),
            }
        ),
        "odom": pl.DataFrame({"t_ns": t_ns, "v": v, "omega": sim.omega_gyro}),
    }


def run_metadata(
    sim: DiffDriveSim, *, conceal: bool = False, extra: Mapping[str, str] | None = None
) -> dict[str, dict[str, str]]:
    """``logcal``: robot, seed and (unless ``conceal``) the true parameters; ``logcal.nominal``:
    what the robot's software believes (radii, track)."""
    rec = {"robot": "diff_drive", "seed": str(sim.seed)}
    if not conceal:
        rec.update({k: repr(float(v)) for k, v in sim.truth().items()})
    rec.update(extra or {})
    nom = sim.config.nominal
    return {
        "logcal": rec,
        "logcal.nominal": {k: repr(float(v)) for k, v in nom.as_dict().items()},
    }


def write_run(
    path: str | os.PathLike[str],
    sim: DiffDriveSim,
    *,
    encoding: Encoding = "json",
    style: Style = "logcal",
    gyro: bool = False,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
) -> int:
    """Write ``sim``; returns the number of messages (CSV: rows).

    Args:
        encoding: ``json`` or ``ros2`` MCAP, or ``csv`` (no metadata; logcal style only).
        style: ``logcal`` topics or ``turtlebot`` (``/joint_states``, ``/cmd_vel``).
        gyro: also write the gyro's yaw rate (``/odom`` omega).
        metadata: records; default :func:`run_metadata`.

    Raises:
        LogWriteError: unknown encoding / style, or the file cannot be written.
    """
    frames = run_frames(sim)
    meta = run_metadata(sim) if metadata is None else metadata
    enc = str(encoding)
    if enc == "csv":
        if style != "logcal":
            raise LogWriteError("a TurtleBot-style log needs an MCAP encoding (json or ros2)")
        cols = dict(CSV_COLUMNS)
        if gyro:
            frames["wheels"] = frames["wheels"].with_columns(frames["odom"]["omega"])
            cols["wheels"] = (*cols["wheels"], "omega")
        return write_frames_csv(path, frames, cols)
    if enc == "json":
        bindings = JSON_BINDINGS if style == "logcal" else _TURTLE_JSON
        if gyro:
            bindings = (*bindings, _GYRO_JSON)
        return write_frames_mcap(path, frames, bindings, JsonEncoder(), metadata=meta)
    if enc == "ros2":
        wheels = (
            TopicBinding(
                "/wheels",
                "wheels",
                "sensor_msgs/msg/JointState",
                {"position.0": "wheel_left", "position.1": "wheel_right"},
                constants={"name": ["left", "right"]},
                stamp_field="header.stamp",
            )
            if style == "logcal"
            else TopicBinding(
                "/joint_states",
                "wheels",
                "sensor_msgs/msg/JointState",
                {"position.0": "wheel_left", "position.1": "wheel_right"},
                constants={"name": _JOINTS},
                stamp_field="header.stamp",
            )
        )
        cmd_topic = "/cmd/vel" if style == "logcal" else "/cmd_vel"
        ros2 = (
            wheels,
            TopicBinding(cmd_topic, "cmd", "geometry_msgs/msg/Twist", _TWIST),
            _POSE_ROS2,
            *((_ODOM_ROS2,) if gyro else ()),
        )
        return write_frames_mcap(path, frames, ros2, CdrEncoder(), metadata=meta)
    raise LogWriteError(f"unknown log encoding {encoding!r}; expected json, ros2 or csv")
