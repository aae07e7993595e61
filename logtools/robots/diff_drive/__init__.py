"""The differential drive (two driven wheels, casters; skid-steer robots with an effective
track): wheel radii and track from wheel angles and ground-truth pose; or, from a log of the
usual ROS kind (the controller's wheel odometry, an IMU, maybe GPS), what that log determines:
the odometry's yaw-rate gain against the gyro and a distance scale against GPS.

This module only declares the plugin (signals, identification, aliases, view paths) and stays
light: every log's robot is resolved by loading all plugin declarations, so the analysis
(:mod:`.pipeline`, with :mod:`calib.diff_drive`'s estimators and scipy) and the report
(:mod:`.report`) are named by import path (``lazy``) and imported on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from logtools.robots.base import RobotPlugin, SignalSpec, lazy
from logtools.signals import SignalSource

if TYPE_CHECKING:
    from logtools.robot_options import RobotOptions
    from logtools.robots.base import Views
    from viz.diff_drive.views import log_views

__all__ = ["PLUGIN"]


def _identify(signals: frozenset[str]) -> str | None:
    if {"wheel_left", "wheel_right"} <= signals:
        return "signals wheel_left, wheel_right"
    if {"odom_omega", "gyro_z"} <= signals:
        return "signals odom_omega (wheel odometry), gyro_z (IMU)"
    return None


def _sources(pairs: tuple[tuple[str, str], ...]) -> tuple[SignalSource, ...]:
    return tuple(SignalSource(t, f) for t, f in pairs)


_WHEELS_TOPIC = "/wheels"
"""LOG_FORMAT.md's wheel angles: fields ``left``/``right`` (JSON), ``position.0``/``.1`` (ROS 2)."""


def _wheel(side: str, index: int) -> SignalSpec:
    """A wheel's cumulative angle: on ``/wheels`` (LOG_FORMAT.md), else on ``/joint_states`` the
    joint whose name holds the side and ``wheel``; an encoder reading 0 throughout is not
    connected."""
    return SignalSpec(
        f"wheel_{side}",
        "rad",
        f"cumulative {side} wheel angle",
        sources=(
            SignalSource(_WHEELS_TOPIC, side),
            SignalSource(_WHEELS_TOPIC, f"position.{index}"),
            SignalSource("/joint_states", f"position.{index}"),
        ),
        empty_when_zero=True,
        joint_words=(side, "wheel"),
    )


_ODOM_TOPICS = ("/odom", "*/odom", "*/wheel_odom", "/odometry/wheel")
_IMU_TOPICS = ("/imu/data", "/imu", "*/imu/data", "*/imu/data_raw", "*/imu")
_GPS_TOPICS = ("/gps/fix", "/fix", "/navsat/fix", "*/gps/fix", "*/fix")


PLUGIN = RobotPlugin(
    name="diff_drive",
    title="differential-drive robot",
    signals=(
        _wheel("right", 1),
        _wheel("left", 0),
        SignalSpec("x", "m", "ground-truth position of the axle centre"),
        SignalSpec("y", "m", "ground-truth position of the axle centre"),
        SignalSpec("yaw", "rad", "ground-truth heading"),
        SignalSpec("omega", "rad/s", "gyro yaw rate (effective track of a skid-steer robot)"),
        SignalSpec("v_cmd", "m/s", "speed command"),
        SignalSpec("omega_cmd", "rad/s", "yaw-rate command"),
        SignalSpec(
            "odom_v",
            "m/s",
            "wheel odometry forward speed (nav_msgs/Odometry twist)",
            sources=_sources(tuple((t, "twist.twist.linear.x") for t in _ODOM_TOPICS)),
        ),
        SignalSpec(
            "odom_omega",
            "rad/s",
            "wheel odometry yaw rate (nav_msgs/Odometry twist)",
            sources=_sources(tuple((t, "twist.twist.angular.z") for t in _ODOM_TOPICS)),
        ),
        SignalSpec(
            "gyro_z",
            "rad/s",
            "IMU yaw rate (sensor_msgs/Imu angular_velocity.z)",
            sources=_sources(tuple((t, "angular_velocity.z") for t in _IMU_TOPICS)),
        ),
        SignalSpec(
            "gps_lat",
            "deg",
            "GPS latitude (sensor_msgs/NavSatFix)",
            sources=_sources(tuple((t, "latitude") for t in _GPS_TOPICS)),
        ),
        SignalSpec(
            "gps_lon",
            "deg",
            "GPS longitude (sensor_msgs/NavSatFix)",
            sources=_sources(tuple((t, "longitude") for t in _GPS_TOPICS)),
        ),
    ),
    identify=_identify,
    analyze=lazy("logtools.robots.diff_drive.pipeline:analyze_diff_drive"),
    report=lazy("logtools.robots.diff_drive.report:report_lines"),
    summary=lazy("logtools.robots.diff_drive.report:summary_lines"),
    pooled_summary=lazy("logtools.robots.diff_drive.report:pooled_summary_lines"),
    pool=lazy("logtools.robots.diff_drive.pipeline:pool_diff_drive"),
    views="viz.diff_drive.views:log_views",
    png="viz.diff_drive.views:write_png",
    aliases=("diff", "differential_drive"),
    identified_by=(("wheel_left", "wheel_right"), ("odom_omega", "gyro_z")),
    span_signals=("wheel_right", "wheel_left", "x", "y", "yaw"),
    simulate="logtools.robots.diff_drive.commands:register_simulate",
    reproduce="logtools.robots.diff_drive.commands:register_reproduce",
)

if TYPE_CHECKING:  # the views named above fill the one Views signature (checked by mypy only)
    _views: Views[RobotOptions] = log_views
