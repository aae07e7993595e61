"""Write a simulated tractor-trailer run
(:class:`calib.tractor_trailer.sim.tractor_trailer.SimulatedRun`) as
an MCAP (JSON or ROS 2) or CSV log exactly per LOG_FORMAT.md."""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import polars as pl

from calib.tractor_trailer.sim.tractor_trailer import SimulatedRun
from logtools.errors import LogWriteError
from logtools.writers.csv_writer import write_frames_csv
from logtools.writers.encoding import ENCODINGS, Encoding, LogEncoding
from logtools.writers.mcap_writer import (
    POSE_ODOMETRY_ROS2,
    CdrEncoder,
    Compression,
    JsonEncoder,
    TopicBinding,
    write_frames_mcap,
)

__all__ = [
    "CSV_COLUMNS",
    "ENCODINGS",
    "JSON_BINDINGS",
    "ROS2_BINDINGS",
    "Encoding",
    "LogEncoding",
    "run_frames",
    "run_metadata",
    "write_csv",
    "write_mcap_json",
    "write_mcap_ros2",
    "write_run",
]

JSON_BINDINGS: tuple[TopicBinding, ...] = (
    TopicBinding("/cmd/curvature", "cmd", "logcal/Curvature", {"curvature": "kappa_cmd"}),
    TopicBinding("/cmd/vel", "cmd", "logcal/VelocityCommand", {"v": "v_cmd", "omega": "omega_cmd"}),
    TopicBinding("/odom", "odom", "logcal/Odometry", {"v": "v", "omega": "omega"}),
    TopicBinding("/pose", "pose", "logcal/Pose2D", {"x": "x", "y": "y", "yaw": "yaw"}),
    TopicBinding("/hitch/angle", "hitch", "logcal/JointAngle", {"angle": "psi"}),
)
"""The JSON topics of LOG_FORMAT.md, fed from the simulator's sensor groups."""

_ODOM_CONST = {"header.frame_id": "odom", "child_frame_id": "base_link"}
ROS2_BINDINGS: tuple[TopicBinding, ...] = (
    TopicBinding("/cmd/curvature", "cmd", "std_msgs/msg/Float64", {"data": "kappa_cmd"}),
    TopicBinding(
        "/cmd/vel",
        "cmd",
        "geometry_msgs/msg/Twist",
        {"linear.x": "v_cmd", "angular.z": "omega_cmd"},
    ),
    TopicBinding(
        "/odom",
        "odom",
        "nav_msgs/msg/Odometry",
        {"twist.twist.linear.x": "v", "twist.twist.angular.z": "omega"},
        constants=_ODOM_CONST,
        stamp_field="header.stamp",
    ),
    POSE_ODOMETRY_ROS2,
    TopicBinding("/hitch/angle", "hitch", "std_msgs/msg/Float64", {"data": "psi"}),
)
"""The ROS 2 topics of LOG_FORMAT.md (yaw as the quaternion (0, 0, sin yaw/2, cos yaw/2))."""

CSV_COLUMNS: dict[str, tuple[str, ...]] = {
    "cmd": ("kappa_cmd", "v_cmd", "omega_cmd"),
    "odom": ("v", "omega"),
    "pose": ("x", "y", "yaw"),
    "hitch": ("psi",),
}
"""Columns of the CSV log per sensor group (logical signal names)."""


def run_frames(run: SimulatedRun) -> dict[str, pl.DataFrame]:
    """The run's measured frames plus derived columns: ``omega_cmd`` = v_cmd kappa_cmd (rad/s)
    in ``cmd``, the yaw quaternion ``qz``, ``qw`` in ``pose``."""
    frames = dict(run.frames)
    frames["cmd"] = frames["cmd"].with_columns(
        (pl.col("v_cmd") * pl.col("kappa_cmd")).alias("omega_cmd")
    )
    yaw = frames["pose"]["yaw"].to_numpy()
    frames["pose"] = frames["pose"].with_columns(
        pl.Series("qz", np.sin(yaw / 2.0)), pl.Series("qw", np.cos(yaw / 2.0))
    )
    return frames


def run_metadata(
    run: SimulatedRun,
    *,
    include_effects: bool = False,
    include_segments: bool = False,
    extra: Mapping[str, str] | None = None,
) -> dict[str, dict[str, str]]:
    """Metadata records for ``run``.

    The ``logcal`` record holds ``robot``, the true ``L1`` and ``L2`` (m, as ``repr`` strings)
    and the simulator ``seed``; injected effects (``actuator_delay_s``, ``sensor_offset.psi``,
    ...) only if ``include_effects`` (logs with concealed effects must not carry their truth).
    ``include_segments`` adds a ``logcal.segments`` record: index -> "type start_s end_s".
    ``extra`` entries are added to ``logcal`` (e.g. ``preset``).
    """
    rec = {"robot": "tractor_trailer", "seed": str(run.seed)}
    for key, value in run.params.items():
        if key in ("L1", "L2") or include_effects:
            rec[key] = repr(float(value))
    rec.update(extra or {})
    out = {"logcal": rec}
    if include_segments:
        out["logcal.segments"] = {
            str(i): f"{s.command_type} {s.start_s!r} {s.end_s!r}"
            for i, s in enumerate(run.segments)
        }
    return out


def write_mcap_json(
    path: str | os.PathLike[str],
    run: SimulatedRun,
    *,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    compression: Compression = "zstd",
    chunked: bool = True,
) -> int:
    """Write ``run`` as a JSON-encoded MCAP (topics and fields of LOG_FORMAT.md).

    Args:
        path: output file.
        run: the simulated run.
        metadata: metadata records; default :func:`run_metadata` of ``run`` (no effects).
        compression: chunk compression, ``zstd``, ``lz4`` or ``none``.
        chunked: write chunks with a message index.

    Returns:
        The number of messages written.

    Raises:
        LogWriteError: the file cannot be written.
    """
    meta = run_metadata(run) if metadata is None else metadata
    return write_frames_mcap(
        path,
        run_frames(run),
        JSON_BINDINGS,
        JsonEncoder(),
        metadata=meta,
        compression=compression,
        chunked=chunked,
    )


def write_mcap_ros2(
    path: str | os.PathLike[str],
    run: SimulatedRun,
    *,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    compression: Compression = "zstd",
) -> int:
    """Write ``run`` as a ROS 2 MCAP (``cdr``; std_msgs/Float64, geometry_msgs/Twist,
    nav_msgs/Odometry as in LOG_FORMAT.md). Arguments as :func:`write_mcap_json`; ROS 2 files
    are always chunked."""
    meta = run_metadata(run) if metadata is None else metadata
    return write_frames_mcap(
        path, run_frames(run), ROS2_BINDINGS, CdrEncoder(), metadata=meta, compression=compression
    )


def write_csv(path: str | os.PathLike[str], run: SimulatedRun) -> int:
    """Write ``run`` as CSV: ``t`` (s from the first sample) and the logical signals, rows on
    the union of the groups' timestamps, empty cells where a group has no sample.

    Returns:
        The number of rows written.
    """
    return write_frames_csv(path, run_frames(run), CSV_COLUMNS)


def write_run(
    path: str | os.PathLike[str],
    run: SimulatedRun,
    *,
    encoding: Encoding = "json",
    metadata: Mapping[str, Mapping[str, str]] | None = None,
) -> int:
    """Write ``run`` in ``encoding`` (``json`` or ``ros2`` MCAP, or ``csv``, which has no
    metadata); return the number of messages (CSV: rows) written.

    Raises:
        LogWriteError: unknown encoding or the file cannot be written.
    """
    if encoding == "json":
        return write_mcap_json(path, run, metadata=metadata)
    if encoding == "ros2":
        return write_mcap_ros2(path, run, metadata=metadata)
    if encoding == "csv":
        return write_csv(path, run)
    raise LogWriteError(
        f"unknown log encoding {encoding!r}; expected one of {', '.join(ENCODINGS)}"
    )
