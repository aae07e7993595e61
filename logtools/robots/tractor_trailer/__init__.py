"""The tractor with an off-axle trailer (the patent's two-link nonholonomic robot): link lengths
L1 (hitch behind link 1's axle, m) and L2 (hitch to trailer axle, m)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import polars as pl

from logtools.curvature import derive_kappa
from logtools.robots.base import RobotPlugin, SignalSpec
from logtools.signals import RobotConfig

__all__ = ["PLUGIN"]


if TYPE_CHECKING:
    from rich.console import RenderableType

    from calib.results import AnalysisResult
    from logtools.load import LoadedLog


# the pipeline imports calib's estimators (scipy): imported on first analysis, so that
# `logcal info` and robot inference stay fast
def _analyze(loaded: LoadedLog, config: Any, progress: Callable[[str], None]) -> AnalysisResult:
    from logtools.robots.tractor_trailer.pipeline import analyze_tractor_trailer

    return analyze_tractor_trailer(loaded, config, progress)


def _pool(
    runs: Sequence[tuple[LoadedLog, AnalysisResult]], config: Any,
    progress: Callable[[str], None],
) -> AnalysisResult:
    from logtools.robots.tractor_trailer.pipeline import pool_tractor_trailer

    return pool_tractor_trailer(runs, config, progress)


def _report(result: AnalysisResult) -> list[RenderableType]:
    from logtools.robots.tractor_trailer.report import report_lines

    return report_lines(result)


def _identify(signals: frozenset[str]) -> str | None:
    return "signal psi" if "psi" in signals else None


def _prepare(frame: pl.DataFrame, robot: RobotConfig) -> pl.DataFrame:
    """The measured curvature ``kappa`` from odometry, pose or steering, where the log has one."""
    has_odom = {"v", "omega"} <= set(frame.columns)
    has_pose = {"x", "y"} <= set(frame.columns)
    has_steer = "steer" in frame.columns and robot.wheelbase is not None
    if has_odom or has_pose or has_steer:
        return derive_kappa(frame, wheelbase=robot.wheelbase)
    return frame


PLUGIN = RobotPlugin(
    name="tractor_trailer",
    title="tractor with an off-axle trailer",
    signals=(
        SignalSpec("psi", "rad", "joint (hitch) angle, 0 when straight", required=True),
        SignalSpec("kappa_cmd", "1/m", "curvature command"),
        SignalSpec("steer", "rad", "steering angle (with the wheelbase: curvature command)"),
        SignalSpec("v", "m/s", "forward speed of link 1's reference point"),
        SignalSpec("omega", "rad/s", "yaw rate of link 1"),
        SignalSpec("x", "m", "position of link 1"),
        SignalSpec("y", "m", "position of link 1"),
        SignalSpec("yaw", "rad", "heading of link 1"),
        SignalSpec("x2", "m", "position of the trailer axle"),
        SignalSpec("y2", "m", "position of the trailer axle"),
        SignalSpec("yaw2", "rad", "heading of the trailer"),
    ),
    identify=_identify,
    analyze=_analyze,
    report=_report,
    pool=_pool,
    views="viz.views:tractor_trailer_rrd",
    png="viz.views:tractor_trailer_png",
    span_signals=("psi", "kappa_cmd", "v", "omega", "x", "y", "yaw"),
    prepare=_prepare,
)
