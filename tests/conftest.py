"""Shared fixtures: a small synthetic drive (known truth) and MCAP writers for it.

The logs are written with the ``mcap`` library's own writers (not logcal's), so the reader is
checked against an independent producer.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from mcap.writer import CompressionType, IndexType, Writer

T0_NS = 1_700_000_000_000_000_000

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}

# ROS 2 message definitions as rosbag2 stores them (dependencies appended after "MSG:" lines).
_SEP = "\n" + "=" * 80 + "\n"
ROS2_FLOAT64 = "float64 data"
ROS2_TWIST = (
    "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular"
    + _SEP
    + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z"
)
ROS2_ODOMETRY = _SEP.join(
    [
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist",
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
        "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance",
        "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\n"
        "geometry_msgs/Quaternion orientation",
        "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z",
        "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w",
        "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance",
        "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular",
        "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
    ]
)
ROS2_JOINT_STATE = _SEP.join(
    [
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort",
        "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
        "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
    ]
)


def drive_truth(n: int = 200, rate_hz: float = 50.0) -> dict[str, np.ndarray]:
    """A tractor-trailer-like drive: harmonic curvature command, unit speed, exact pose."""
    t = np.arange(n) / rate_hz
    kappa = 0.2 * np.sin(0.5 * t)
    yaw = 0.4 * (1 - np.cos(0.5 * t))  # integral of v * kappa with v = 1
    return {
        "t_ns": T0_NS + np.round(t * 1e9).astype(np.int64),
        "kappa_cmd": kappa,
        "v": np.ones(n),
        "omega": kappa,
        "x": np.cumsum(np.cos(yaw)) / rate_hz,
        "y": np.cumsum(np.sin(yaw)) / rate_hz,
        "yaw": yaw,
        "psi": 0.3 * np.sin(0.5 * t - 0.2),
    }


JSON_TOPICS: dict[str, dict[str, str]] = {
    "/cmd/curvature": {"curvature": "kappa_cmd"},
    "/odom": {"v": "v", "omega": "omega"},
    "/pose": {"x": "x", "y": "y", "yaw": "yaw"},
    "/hitch/angle": {"angle": "psi"},
}


def write_json_mcap(
    path: Path,
    truth: dict[str, np.ndarray],
    *,
    chunked: bool = True,
    compression: str = "zstd",
    summary: bool = True,
    chunk_size: int = 1024,
    metadata: dict[str, str] | None = None,
    topics: dict[str, dict[str, str]] | None = None,
) -> Path:
    """Write ``truth`` as LOG_FORMAT's JSON topics (field -> truth key per topic)."""
    with path.open("wb") as fh:
        w = Writer(
            fh,
            chunk_size=chunk_size,
            compression=_COMPRESSION[compression],
            use_chunking=chunked,
            index_types=IndexType.ALL if summary else IndexType.NONE,
            repeat_channels=summary,
            repeat_schemas=summary,
            use_statistics=summary,
            use_summary_offsets=summary,
        )
        w.start("", "logcal-tests")
        ids = {}
        for topic, fields in (topics or JSON_TOPICS).items():
            schema = {"type": "object", "properties": {f: {"type": "number"} for f in fields}}
            sid = w.register_schema(topic.strip("/"), "jsonschema", json.dumps(schema).encode())
            ids[topic] = w.register_channel(topic, "json", sid)
        for i, t in enumerate(truth["t_ns"]):
            for topic, fields in (topics or JSON_TOPICS).items():
                msg = {f: float(truth[key][i]) for f, key in fields.items()}
                w.add_message(ids[topic], int(t), json.dumps(msg).encode(), int(t), sequence=i)
        if metadata is not None:
            w.add_metadata("logcal", metadata)
        w.finish()
    return path


def write_ros2_mcap(
    path: Path,
    truth: dict[str, np.ndarray],
    *,
    compression: str = "zstd",
    wheels_swapped: bool = False,
) -> Path:
    """Write ``truth`` with ROS 2 standard types (LOG_FORMAT.md), plus a JointState /wheels."""
    from mcap_ros2.writer import Writer as Ros2Writer

    with path.open("wb") as fh:
        w = Ros2Writer(fh, chunk_size=2048, compression=_COMPRESSION[compression])
        f64 = w.register_msgdef("std_msgs/msg/Float64", ROS2_FLOAT64)
        odom = w.register_msgdef("nav_msgs/msg/Odometry", ROS2_ODOMETRY)
        joint = w.register_msgdef("sensor_msgs/msg/JointState", ROS2_JOINT_STATE)
        names = ["right_wheel_joint", "left_wheel_joint"] if wheels_swapped else ["left", "right"]
        for i, t in enumerate(truth["t_ns"]):
            t = int(t)
            stamp = {"sec": t // 10**9, "nanosec": t % 10**9}
            yaw = truth["yaw"][i]
            quat = {"x": 0.0, "y": 0.0, "z": np.sin(yaw / 2), "w": np.cos(yaw / 2)}
            w.write_message("/cmd/curvature", f64, {"data": truth["kappa_cmd"][i]}, t, t)
            w.write_message("/hitch/angle", f64, {"data": truth["psi"][i]}, t, t)
            pose = {"position": {"x": truth["x"][i], "y": truth["y"][i], "z": 0.0}}
            twist = {"linear": {"x": truth["v"][i]}, "angular": {"z": truth["omega"][i]}}
            header = {"stamp": stamp, "frame_id": "odom"}
            w.write_message(
                "/odom",
                odom,
                {"header": header, "twist": {"twist": twist, "covariance": [0.0] * 36}},
                t,
                t,
            )
            pose_msg = {"pose": {**pose, "orientation": quat}, "covariance": [0.0] * 36}
            w.write_message("/pose", odom, {"header": header, "pose": pose_msg}, t, t)
            left, right = 10.0 * truth["x"][i], 12.0 * truth["x"][i]
            position = [right, left] if wheels_swapped else [left, right]
            w.write_message(
                "/wheels", joint, {"header": header, "name": names, "position": position}, t, t
            )
        w.finish()
    return path


@pytest.fixture(scope="session")
def truth() -> dict[str, np.ndarray]:
    """The synthetic drive of :func:`drive_truth` (200 samples at 50 Hz)."""
    return drive_truth()


@pytest.fixture(scope="session")
def mcap_writers() -> SimpleNamespace:
    """The log writers above (and ``truth(n)`` for longer drives), for tests to call."""
    return SimpleNamespace(json=write_json_mcap, ros2=write_ros2_mcap, truth=drive_truth)
