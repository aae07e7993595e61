"""The differential drive (two driven wheels, casters; skid-steer robots with an effective
track): wheel radii and track from wheel angles and ground-truth pose.

This module only declares the plugin (signals, identification, aliases, view paths) and stays
light: every log's robot is resolved by loading all plugin declarations, so the analysis
(:mod:`.pipeline`, with :mod:`calib.diff_drive`'s estimators and scipy) and the report
(:mod:`.report`) are named by import path (``lazy``) and imported on first use.
"""

from __future__ import annotations

from logtools.robots.base import RobotPlugin, SignalSpec, lazy

__all__ = ["PLUGIN"]


def _identify(signals: frozenset[str]) -> str | None:
    if {"wheel_left", "wheel_right"} <= signals:
        return "signals wheel_left, wheel_right"
    return None


PLUGIN = RobotPlugin(
    name="diff_drive",
    title="differential-drive robot",
    signals=(
        SignalSpec("wheel_right", "rad", "cumulative right wheel angle", required=True),
        SignalSpec("wheel_left", "rad", "cumulative left wheel angle", required=True),
        SignalSpec("x", "m", "ground-truth position of the axle centre"),
        SignalSpec("y", "m", "ground-truth position of the axle centre"),
        SignalSpec("yaw", "rad", "ground-truth heading"),
        SignalSpec("omega", "rad/s", "gyro yaw rate (effective track of a skid-steer robot)"),
        SignalSpec("v_cmd", "m/s", "speed command"),
        SignalSpec("omega_cmd", "rad/s", "yaw-rate command"),
    ),
    identify=_identify,
    analyze=lazy("logtools.robots.diff_drive.pipeline:analyze_diff_drive"),
    report=lazy("logtools.robots.diff_drive.report:report_lines"),
    pool=lazy("logtools.robots.diff_drive.pipeline:pool_diff_drive"),
    views="viz.diff_drive:log_views",
    png="viz.diff_drive:write_png",
    aliases=("diff", "differential_drive"),
    span_signals=("wheel_right", "wheel_left", "x", "y", "yaw"),
)
