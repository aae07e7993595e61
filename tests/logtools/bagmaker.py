"""Small ROS bags for tests, written with ``rosbags`` (an independent producer).

The drive is a user's small tractor-trailer: ``/cmd_vel`` (Twist, 7 Hz, linear.x = speed,
angular.z = STEERING ANGLE), ``/encoder/angle`` (Float32, 54 Hz, hitch angle), ``/odom``
(Odometry, 29 Hz, the TRAILER pose, twist all zeros), ``/truck_trailer/truck_pose``
(PoseStamped, 29 Hz, tractor pose), ``/kelo_angle`` (Float32, 20 Hz, measured steering angle)
and ``/tf`` (map -> truck_link). A recorder stall of ``stall_s`` removes every message from
all topics at once.

Formats: a Foxy-style rosbag2 folder (sqlite3, metadata.yaml version 4, no type definitions
stored, written by hand as ROS 2 Foxy does), a rosbag2 folder with mcap storage (rosbags'
writer), and a ROS 1 ``.bag`` (rosbags' writer).
"""

from __future__ import annotations

import math
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

T0_NS = 1_650_000_000_000_000_000
WHEELBASE = 0.42
HITCH_TO_AXLE = 0.6  # trailer axle behind the tractor's reference point (m)


@dataclass
class Drive:
    """Truth of the drive and the per-topic sample times."""

    duration_s: float = 30.0
    v: float = 0.3
    stall: tuple[float, float] | None = (12.0, 14.3)
    header_offset_s: float = 0.0  # header stamps = record time - this
    zero_twist: bool = True
    steer_amp: float = 0.35
    times: dict[str, np.ndarray] = field(default_factory=dict)

    def steer(self, t: np.ndarray) -> np.ndarray:
        return self.steer_amp * np.sin(0.25 * t)

    def psi(self, t: np.ndarray) -> np.ndarray:
        return 0.25 * np.sin(0.25 * t - 0.4)

    def pose(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tractor pose (x, y, yaw) integrated finely from v and tan(steer)/wheelbase."""
        fine = np.arange(0.0, self.duration_s + 0.01, 0.001)
        rate = self.v * np.tan(self.steer(fine)) / WHEELBASE
        yaw = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 0.001)])
        x = np.concatenate([[0.0], np.cumsum(self.v * np.cos(yaw[:-1]) * 0.001)])
        y = np.concatenate([[0.0], np.cumsum(self.v * np.sin(yaw[:-1]) * 0.001)])
        return np.interp(t, fine, x), np.interp(t, fine, y), np.interp(t, fine, yaw)

    def sample_times(self, rate_hz: float, phase: float) -> np.ndarray:
        t = np.arange(phase / rate_hz, self.duration_s, 1.0 / rate_hz)
        if self.stall is not None:
            t = t[(t < self.stall[0]) | (t >= self.stall[1])]
        return t


RATES = {
    "/cmd_vel": 7.0,
    "/encoder/angle": 54.0,
    "/odom": 29.0,
    "/truck_trailer/truck_pose": 29.0,
    "/kelo_angle": 20.0,
    "/tf": 29.0,
}
TYPES = {
    "/cmd_vel": "geometry_msgs/msg/Twist",
    "/encoder/angle": "std_msgs/msg/Float32",
    "/odom": "nav_msgs/msg/Odometry",
    "/truck_trailer/truck_pose": "geometry_msgs/msg/PoseStamped",
    "/kelo_angle": "std_msgs/msg/Float32",
    "/tf": "tf2_msgs/msg/TFMessage",
}


def _quat(ts: Any, yaw: float) -> Any:
    q = ts.types["geometry_msgs/msg/Quaternion"]
    return q(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _header(ts: Any, t_s: float, frame: str, ros1: bool) -> Any:
    time = ts.types["builtin_interfaces/msg/Time"]
    ns = T0_NS + round(t_s * 1e9)
    stamp = time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    header = ts.types["std_msgs/msg/Header"]
    if ros1:
        return header(seq=0, stamp=stamp, frame_id=frame)
    return header(stamp=stamp, frame_id=frame)


def messages(drive: Drive, ts: Any, ros1: bool = False) -> list[tuple[str, int, Any]]:
    """(topic, record time ns, message) for the whole drive, sorted by time."""
    T = ts.types
    vec, point, pose_t = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Point"], None
    pose_t = T["geometry_msgs/msg/Pose"]
    out: list[tuple[str, int, Any]] = []
    for k, (topic, rate) in enumerate(RATES.items()):
        t = drive.sample_times(rate, 0.1 * k)
        drive.times[topic] = t
        x, y, yaw = drive.pose(t)
        psi = drive.psi(t)
        steer = drive.steer(t)
        for i, ti in enumerate(t):
            hs = ti - drive.header_offset_s
            if topic == "/cmd_vel":
                msg = T["geometry_msgs/msg/Twist"](
                    linear=vec(x=drive.v, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=steer[i])
                )
            elif topic == "/encoder/angle":
                msg = T["std_msgs/msg/Float32"](data=float(psi[i]))
            elif topic == "/kelo_angle":
                msg = T["std_msgs/msg/Float32"](data=float(steer[i]))
            elif topic == "/truck_trailer/truck_pose":
                msg = T["geometry_msgs/msg/PoseStamped"](
                    header=_header(ts, hs, "map", ros1),
                    pose=pose_t(
                        position=point(x=x[i], y=y[i], z=0.0), orientation=_quat(ts, yaw[i])
                    ),
                )
            elif topic == "/odom":  # the trailer pose; the twist is all zeros
                yaw2 = yaw[i] - psi[i]
                x2 = x[i] - HITCH_TO_AXLE * math.cos(yaw2)
                y2 = y[i] - HITCH_TO_AXLE * math.sin(yaw2)
                twist_v = 0.0 if drive.zero_twist else drive.v
                msg = T["nav_msgs/msg/Odometry"](
                    header=_header(ts, hs, "map", ros1),
                    child_frame_id="trailer",
                    pose=T["geometry_msgs/msg/PoseWithCovariance"](
                        pose=pose_t(position=point(x=x2, y=y2, z=0.0), orientation=_quat(ts, yaw2)),
                        covariance=np.zeros(36),
                    ),
                    twist=T["geometry_msgs/msg/TwistWithCovariance"](
                        twist=T["geometry_msgs/msg/Twist"](
                            linear=vec(x=twist_v, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)
                        ),
                        covariance=np.zeros(36),
                    ),
                )
            else:  # /tf: map -> truck_link, plus an unrelated frame in every other message
                tfs = T["geometry_msgs/msg/TransformStamped"]
                trans = T["geometry_msgs/msg/Transform"]
                items = [
                    tfs(
                        header=_header(ts, hs, "map", ros1),
                        child_frame_id="truck_link",
                        transform=trans(
                            translation=vec(x=x[i], y=y[i], z=0.0), rotation=_quat(ts, yaw[i])
                        ),
                    )
                ]
                if i % 2:
                    items.insert(
                        0,
                        tfs(
                            header=_header(ts, hs, "truck_link", ros1),
                            child_frame_id="lidar",
                            transform=trans(
                                translation=vec(x=0.1, y=0.0, z=0.3), rotation=_quat(ts, 0.0)
                            ),
                        ),
                    )
                msg = T["tf2_msgs/msg/TFMessage"](transforms=items)
            out.append((topic, T0_NS + round(ti * 1e9), msg))
    out.sort(key=lambda m: m[1])
    return out


def write_foxy_db3(path: Path, drive: Drive) -> Path:
    """A rosbag2 folder as ROS 2 Foxy records it: sqlite3, metadata version 4, no type defs."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_FOXY)
    msgs = messages(drive, ts)
    path.mkdir(parents=True)
    db = path / f"{path.name}_0.db3"
    con = sqlite3.connect(db)
    con.executescript(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
        "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
    )
    ids = {topic: i + 1 for i, topic in enumerate(RATES)}
    for topic, i in ids.items():
        con.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", (i, topic, TYPES[topic]))
    counts = dict.fromkeys(RATES, 0)
    for topic, t_ns, msg in msgs:
        data = bytes(ts.serialize_cdr(msg, TYPES[topic]))
        con.execute(
            "INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)",
            (ids[topic], t_ns, data),
        )
        counts[topic] += 1
    con.commit()
    con.close()
    start, end = msgs[0][1], msgs[-1][1]
    topics = "".join(
        f"    - topic_metadata:\n        name: {topic}\n        type: {TYPES[topic]}\n"
        f"        serialization_format: cdr\n        offered_qos_profiles: ''\n"
        f"      message_count: {counts[topic]}\n"
        for topic in RATES
    )
    (path / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  version: 4\n  storage_identifier: sqlite3\n"
        f"  relative_file_paths:\n    - {db.name}\n"
        f"  duration:\n    nanoseconds: {end - start}\n"
        f"  starting_time:\n    nanoseconds_since_epoch: {start}\n"
        f"  message_count: {len(msgs)}\n  topics_with_message_count:\n{topics}"
        "  compression_format: ''\n  compression_mode: ''\n"
    )
    return path


def write_rosbag2(
    path: Path, drive: Drive, storage: str = "mcap", custom: dict | None = None
) -> Path:
    """A rosbag2 folder written by rosbags (definitions stored), sqlite3 or mcap storage."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    msgs = messages(drive, ts)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        for key, value in (custom or {}).items():
            writer.set_custom_data(key, value)
        conns = {t: writer.add_connection(t, TYPES[t], typestore=ts) for t in RATES}
        for topic, t_ns, msg in msgs:
            writer.write(conns[topic], t_ns, ts.serialize_cdr(msg, TYPES[topic]))
    return path


def write_ros1(path: Path, drive: Drive) -> Path:
    """A ROS 1 bag written by rosbags."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)  # has no tf2_msgs: define TFMessage as ROS 1 does
    ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TYPES["/tf"]))
    msgs = messages(drive, ts, ros1=True)
    with Writer(path) as writer:
        conns = {t: writer.add_connection(t, TYPES[t], typestore=ts) for t in RATES}
        for topic, t_ns, msg in msgs:
            writer.write(conns[topic], t_ns, ts.serialize_ros1(msg, TYPES[topic]))
    return path
