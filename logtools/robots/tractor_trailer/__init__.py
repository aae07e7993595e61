"""The tractor with an off-axle trailer (the patent's two-link nonholonomic robot): link lengths
L1 (hitch behind link 1's axle, m) and L2 (hitch to trailer axle, m). Its curvature command
``kappa_cmd``, when a log lacks it, is derived from a steering or velocity command
(``derived_signals``, :mod:`logtools.robots.tractor_trailer.curvature`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from logtools.robots.base import RobotPlugin, SignalDerivation, SignalSpec, lazy
from logtools.robots.tractor_trailer.options import TractorTrailerOptions
from logtools.signals import RobotKey, SignalSource

if TYPE_CHECKING:
    import polars as pl

    from logtools.robots.base import SamplesFn, Views
    from logtools.robots.tractor_trailer.samples import write_samples
    from logtools.signals import RobotConfig
    from viz.tractor_trailer.views import tractor_trailer_rrd

__all__ = ["JSON_SOURCES", "PLUGIN", "ROS2_SOURCES", "WHEELBASE", "TractorTrailerOptions"]

# the pipeline imports calib's estimators (scipy): named by import path and imported on first
# analysis (``lazy``), so that `logcal info` and robot inference stay fast; polars too is imported
# only when a frame is prepared or a signal derived (the CLI loads every declaration to offer the
# robots' options)
_CURVATURE = "logtools.robots.tractor_trailer.curvature"


JSON_SOURCES: dict[str, SignalSource] = {
    "psi": SignalSource("/hitch/angle", "angle"),
    "kappa_cmd": SignalSource("/cmd/curvature", "curvature"),
}
"""Where the JSON encoding ``logcal simulate`` writes (LOG_FORMAT.md) holds the tractor's own
signals."""

ROS2_SOURCES: dict[str, SignalSource] = {
    "psi": SignalSource("/hitch/angle", "data"),
    "kappa_cmd": SignalSource("/cmd/curvature", "data"),
}
"""The same topics as ROS 2 standard types (``std_msgs/Float64``)."""

_TRAILER = "trailer"

WHEELBASE = "wheelbase"
"""The ``[robot]`` key (and metadata entry) of the tractor's wheelbase (m)."""


def _identify(signals: frozenset[str]) -> str | None:
    return "signal psi" if "psi" in signals else None


def _prepare(frame: pl.DataFrame, robot: RobotConfig) -> pl.DataFrame:
    """The measured curvature ``kappa`` from odometry, pose or steering, where the log has one."""
    from logtools.robots.tractor_trailer.curvature import derive_kappa

    has_odom = {"v", "omega"} <= set(frame.columns)
    has_pose = {"x", "y"} <= set(frame.columns)
    wheelbase = robot.number(WHEELBASE)
    has_steer = "steer" in frame.columns and wheelbase is not None
    if has_odom or has_pose or has_steer:
        return derive_kappa(frame, wheelbase=wheelbase)
    return frame


PLUGIN = RobotPlugin(
    name="tractor_trailer",
    title="tractor with an off-axle trailer",
    signals=(
        SignalSpec(
            "psi",
            "rad",
            "joint (hitch) angle, 0 when straight",
            required=True,
            sources=(JSON_SOURCES["psi"], ROS2_SOURCES["psi"]),
            empty_when_zero=True,
            within_turn=True,
        ),
        SignalSpec(
            "kappa_cmd",
            "1/m",
            "curvature command",
            sources=(JSON_SOURCES["kappa_cmd"], ROS2_SOURCES["kappa_cmd"]),
            command=True,
        ),
        SignalSpec(
            "steer",
            "rad",
            "steering angle (with the wheelbase: curvature command)",
            empty_when_zero=True,
        ),
        SignalSpec("steer_cmd", "rad", "steering command", command=True),
        SignalSpec("v", "m/s", "forward speed of link 1's reference point"),
        SignalSpec("omega", "rad/s", "yaw rate of link 1"),
        SignalSpec("x", "m", "position of link 1"),
        SignalSpec("y", "m", "position of link 1"),
        SignalSpec("yaw", "rad", "heading of link 1"),
        SignalSpec("x2", "m", "position of the trailer axle", body=_TRAILER),
        SignalSpec("y2", "m", "position of the trailer axle", body=_TRAILER),
        SignalSpec(
            "yaw2",
            "rad",
            "heading of the trailer",
            empty_when_zero=True,
            heading=True,
            body=_TRAILER,
        ),
    ),
    identify=_identify,
    analyze=lazy("logtools.robots.tractor_trailer.pipeline:analyze_tractor_trailer"),
    report=lazy("logtools.robots.tractor_trailer.report:report_lines"),
    pool=lazy("logtools.robots.tractor_trailer.pipeline:pool_tractor_trailer"),
    views="viz.tractor_trailer.views:tractor_trailer_rrd",
    png="viz.tractor_trailer.views:tractor_trailer_png",
    span_signals=("psi", "kappa_cmd", "v", "omega", "x", "y", "yaw"),
    prepare=_prepare,
    derived_signals=(
        SignalDerivation(
            "kappa_cmd",
            derive=lazy(f"{_CURVATURE}:derive_kappa_cmd"),
            check=lazy(f"{_CURVATURE}:saturated_steer_notes"),
        ),
    ),
    derive_pooled=lazy("calib.tractor_trailer.derived:pooled_derived"),
    options=TractorTrailerOptions,
    simulate="logtools.robots.tractor_trailer.commands:register_simulate",
    reproduce="logtools.robots.tractor_trailer.commands:register_reproduce",
    samples="logtools.robots.tractor_trailer.samples:write_samples",
    robot_keys=(
        RobotKey(
            WHEELBASE,
            "the distance from the steered axle to the fixed axle of a car-like tractor "
            "(kappa = tan(delta) / wheelbase)",
            positive=True,
            from_metadata=True,
        ),
    ),
)

if TYPE_CHECKING:  # the functions named above fill their signatures (checked by mypy only)
    _views: Views[TractorTrailerOptions] = tractor_trailer_rrd
    _samples: SamplesFn = write_samples
