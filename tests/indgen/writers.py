"""Writers of generated logs: MCAP (JSON and ROS 2), CSV, rosbag2 (sqlite3 or mcap) and ROS 1.

Written with the ``mcap``, ``mcap_ros2`` and ``rosbags`` libraries directly. Messages of all
topics are written in the order of their stamps; the log time (bag timestamp) of a message
equals its stamp, and header stamps (where the type has a header) carry the same value.
MCAP files get a metadata record ``logcal`` (robot = tractor_trailer, L1, L2 as strings) unless
``metadata=False``; the truth of the effects is never written.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
from mcap.writer import CompressionType, Writer
from mcap_ros2.writer import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from .generate import Generated, TopicData

__all__ = [
    "CSV_COLUMNS",
    "ROS_TYPES",
    "write_csv",
    "write_mcap_json",
    "write_mcap_ros2",
    "write_rosbag1",
    "write_rosbag2",
]

ROS_TYPES: dict[str, dict[str, str]] = {
    "tractor_trailer": {
        "cmd": "std_msgs/msg/Float64",
        "cmd_vel": "geometry_msgs/msg/Twist",
        "odom": "nav_msgs/msg/Odometry",
        "pose": "nav_msgs/msg/Odometry",
        "hitch": "std_msgs/msg/Float64",
    },
    "small_tractor_trailer": {
        "cmd_vel": "geometry_msgs/msg/Twist",
        "encoder": "std_msgs/msg/Float32",
        "odom": "nav_msgs/msg/Odometry",
        "truck_pose": "geometry_msgs/msg/PoseStamped",
        "kelo": "std_msgs/msg/Float32",
        "tf": "tf2_msgs/msg/TFMessage",
    },
}
"""ROS message type per robot class and topic group."""

CSV_COLUMNS: dict[tuple[str, str], str] = {
    ("cmd", "curvature"): "kappa_cmd",
    ("cmd_vel", "v"): "v_cmd",
    ("odom", "v"): "v",
    ("odom", "omega"): "omega",
    ("pose", "x"): "x",
    ("pose", "y"): "y",
    ("pose", "yaw"): "yaw",
    ("hitch", "angle"): "psi",
}
"""CSV column of each (group, field) of the tractor_trailer robot (/cmd/vel omega is left out)."""

_FRAMES = {  # (header frame_id, child_frame_id) per (robot, group)
    ("tractor_trailer", "odom"): ("odom", "base_link"),
    ("tractor_trailer", "pose"): ("map", "base_link"),
    ("small_tractor_trailer", "odom"): ("map", "trailer_link"),
    ("small_tractor_trailer", "truck_pose"): ("map", "truck_link"),
    ("small_tractor_trailer", "tf"): ("map", "truck_link"),
}


def _metadata(gen: Generated) -> dict[str, str]:
    s = gen.scenario
    return {"robot": "tractor_trailer", "L1": repr(s.L1), "L2": repr(s.L2)}


def _ordered(gen: Generated) -> Iterator[tuple[TopicData, int]]:
    """(topic, index) of every message, in stamp order (stable across topics)."""
    tops = list(gen.topics.values())
    if not tops:
        return
    stamps = np.concatenate([td.stamps_ns for td in tops])
    which = np.concatenate([np.full(td.stamps_ns.size, k) for k, td in enumerate(tops)])
    index = np.concatenate([np.arange(td.stamps_ns.size) for td in tops])
    for j in np.argsort(stamps, kind="stable"):
        yield tops[int(which[j])], int(index[j])


def write_mcap_json(
    path: str | Path, gen: Generated, *, metadata: bool = True, compression: str = "zstd"
) -> None:
    """MCAP with JSON messages (jsonschema schemas), fields as in LOG_FORMAT.md."""
    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
    with open(path, "wb") as fh:
        w = Writer(fh, compression=comp[compression])
        w.start(profile="", library="indgen")
        channels: dict[str, int] = {}
        for td in gen.topics.values():
            schema = {
                "type": "object",
                "properties": {f: {"type": "number"} for f in td.fields},
                "required": list(td.fields),
            }
            sid = w.register_schema(
                name=f"indgen.{td.group}", encoding="jsonschema", data=json.dumps(schema).encode()
            )
            channels[td.topic] = w.register_channel(td.topic, "json", sid)
        seq: dict[str, int] = dict.fromkeys(channels, 0)
        for td, i in _ordered(gen):
            msg = {f: float(a[i]) for f, a in td.fields.items()}
            t = int(td.stamps_ns[i])
            w.add_message(channels[td.topic], t, json.dumps(msg).encode(), t, seq[td.topic])
            seq[td.topic] += 1
        if metadata:
            w.add_metadata("logcal", _metadata(gen))
        w.finish()


# ---- ROS messages (built as rosbags objects; converted to dicts for mcap_ros2) -------------


def _quat(ts: Typestore, yaw: float) -> Any:
    Q = ts.types["geometry_msgs/msg/Quaternion"]
    return Q(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _header(ts: Typestore, stamp_ns: int, frame: str, seq: int) -> Any:
    Time = ts.types["builtin_interfaces/msg/Time"]
    H = ts.types["std_msgs/msg/Header"]
    t = Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))
    names = [f[0] for f in ts.fielddefs["std_msgs/msg/Header"][1]]
    if "seq" in names:
        return H(seq=seq, stamp=t, frame_id=frame)
    return H(stamp=t, frame_id=frame)


def _vec(ts: Typestore, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
    return ts.types["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def _pose(ts: Typestore, f: dict[str, float]) -> Any:
    P = ts.types["geometry_msgs/msg/Pose"]
    Pt = ts.types["geometry_msgs/msg/Point"]
    x, y, yaw = f.get("x", 0.0), f.get("y", 0.0), f.get("yaw", 0.0)
    return P(position=Pt(x=x, y=y, z=0.0), orientation=_quat(ts, yaw))


def _message(ts: Typestore, gen: Generated, td: TopicData, i: int) -> tuple[str, Any]:
    """(msgtype, rosbags message) of message ``i`` of topic ``td``."""
    robot = gen.scenario.robot
    msgtype = ROS_TYPES[robot][td.group]
    f = {k: float(a[i]) for k, a in td.fields.items()}
    stamp = int(td.stamps_ns[i])
    frame, child = _FRAMES.get((robot, td.group), ("", ""))
    if msgtype in ("std_msgs/msg/Float64", "std_msgs/msg/Float32"):
        return msgtype, ts.types[msgtype](data=next(iter(f.values())))
    if msgtype == "geometry_msgs/msg/Twist":
        first, second = td.fields  # (v, omega) or (v, delta)
        return msgtype, ts.types[msgtype](linear=_vec(ts, f[first]), angular=_vec(ts, z=f[second]))
    header = _header(ts, stamp, frame, i)
    if msgtype == "nav_msgs/msg/Odometry":
        Tw = ts.types["geometry_msgs/msg/Twist"]
        twist = Tw(linear=_vec(ts, f.get("v", 0.0)), angular=_vec(ts, z=f.get("omega", 0.0)))
        cov = np.zeros(36, dtype=np.float64)
        return msgtype, ts.types[msgtype](
            header=header,
            child_frame_id=child,
            pose=ts.types["geometry_msgs/msg/PoseWithCovariance"](
                pose=_pose(ts, f), covariance=cov
            ),
            twist=ts.types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=cov),
        )
    if msgtype == "geometry_msgs/msg/PoseStamped":
        return msgtype, ts.types[msgtype](header=header, pose=_pose(ts, f))
    if msgtype == "tf2_msgs/msg/TFMessage":
        tr = ts.types["geometry_msgs/msg/Transform"](
            translation=_vec(ts, f["x"], f["y"]), rotation=_quat(ts, f["yaw"])
        )
        st = ts.types["geometry_msgs/msg/TransformStamped"](
            header=header, child_frame_id=child, transform=tr
        )
        return msgtype, ts.types[msgtype](transforms=[st])
    raise ValueError(f"no message builder for {msgtype}")


def _to_dict(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {
            fl.name: _to_dict(getattr(obj, fl.name))
            for fl in dataclasses.fields(obj)
            if not fl.name.startswith("__")
        }
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, list):
        return [_to_dict(x) for x in obj]
    return obj


def write_mcap_ros2(path: str | Path, gen: Generated, *, metadata: bool = True) -> None:
    """MCAP with ROS 2 messages (cdr, ros2msg) via ``mcap_ros2.writer``; types ``ROS_TYPES``."""
    ts = get_typestore(Stores.ROS2_FOXY)
    with open(path, "wb") as fh:
        w = Ros2Writer(fh)
        schemas: dict[str, Any] = {}
        for td in gen.topics.values():
            mt = ROS_TYPES[gen.scenario.robot][td.group]
            if mt not in schemas:
                schemas[mt] = w.register_msgdef(mt, ts.generate_msgdef(mt, ros_version=2)[0])
        seq: dict[str, int] = dict.fromkeys(gen.topics, 0)
        for td, i in _ordered(gen):
            mt, msg = _message(ts, gen, td, i)
            t = int(td.stamps_ns[i])
            w.write_message(td.topic, schemas[mt], _to_dict(msg), t, t, seq[td.topic])
            seq[td.topic] += 1
        if metadata:
            w.add_metadata("logcal", _metadata(gen))
        w.finish()


def write_csv(path: str | Path, gen: Generated) -> None:
    """CSV of a tractor_trailer log: ``t`` (s since ``scenario.start_ns``; negative for samples
    stamped early) and the columns of ``CSV_COLUMNS`` that are present; one row per distinct
    stamp, empty cells where a topic has no sample at that stamp."""
    if gen.scenario.robot != "tractor_trailer":
        raise ValueError("write_csv writes the tractor_trailer robot's logical signals only")
    tops = list(gen.topics.values())
    stamps = np.unique(np.concatenate([td.stamps_ns for td in tops]))
    cols: dict[str, np.ndarray] = {}
    for td in tops:
        rows = np.searchsorted(stamps, td.stamps_ns)
        for f, a in td.fields.items():
            name = CSV_COLUMNS.get((td.group, f))
            if name is None:
                continue
            col = cols.setdefault(name, np.full(stamps.size, np.nan))
            col[rows] = a
    order = [c for c in CSV_COLUMNS.values() if c in cols]
    write_csv_rows(path, (stamps - gen.scenario.start_ns) / 1e9, cols, order)


def write_csv_rows(
    path: str | Path, t: np.ndarray, cols: dict[str, np.ndarray], order: list[str]
) -> None:
    """A CSV with the time column ``t`` (s) and ``cols`` in ``order``; NaN cells left empty."""
    with open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["t", *order])
        for k in range(t.size):
            row = [f"{t[k]:.9f}"]
            for c in order:
                x = cols[c][k]
                row.append("" if np.isnan(x) else repr(float(x)))
            wr.writerow(row)


def write_rosbag2(
    path: str | Path, gen: Generated, storage: Literal["sqlite3", "mcap"] = "sqlite3"
) -> None:
    """A rosbag2 folder at ``path`` (must not exist) written with ``rosbags`` (CDR, Foxy types),
    storage ``sqlite3`` (.db3) or ``mcap``."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Bag2Writer

    ts = get_typestore(Stores.ROS2_FOXY)
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Bag2Writer(path, version=8, storage_plugin=plugin) as w:
        conns = {
            td.topic: w.add_connection(
                td.topic, ROS_TYPES[gen.scenario.robot][td.group], typestore=ts
            )
            for td in gen.topics.values()
        }
        for td, i in _ordered(gen):
            mt, msg = _message(ts, gen, td, i)
            w.write(conns[td.topic], int(td.stamps_ns[i]), ts.serialize_cdr(msg, mt))


def write_rosbag1(path: str | Path, gen: Generated) -> None:
    """A ROS 1 bag file at ``path`` written with ``rosbags`` (Noetic types; tf2_msgs/TFMessage
    registered from its one-line definition)."""
    from rosbags.rosbag1 import Writer as Bag1Writer
    from rosbags.typesys import get_types_from_msg

    ts = get_typestore(Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in ts.fielddefs:
        ts.register(
            get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
    with Bag1Writer(path) as w:
        conns = {
            td.topic: w.add_connection(
                td.topic, ROS_TYPES[gen.scenario.robot][td.group], typestore=ts
            )
            for td in gen.topics.values()
        }
        for td, i in _ordered(gen):
            mt, msg = _message(ts, gen, td, i)
            w.write(conns[td.topic], int(td.stamps_ns[i]), ts.serialize_ros1(msg, mt))
