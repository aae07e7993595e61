"""The bulk ROS 2 decoder (cdr_bulk) gives exactly the per-message path's frame, or steps aside."""

from __future__ import annotations

import subprocess
import sys
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.records import Channel, Schema
from mcap_ros2.writer import Writer
from polars.testing import assert_frame_equal

from logtools.readers.cdr_bulk import decode_cdr_bulk
from logtools.readers.decoders import decode_cdr, decode_cdr_each
from logtools.readers.mcap_scan import Payloads, scan_mcap
from logtools.writers.ros2_msgdefs import MSGDEFS

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"
_SEP = "\n" + "=" * 80 + "\n"
EXTRA = {
    "std_msgs/msg/Float32": "float32 data",
    "geometry_msgs/msg/TwistStamped": "std_msgs/Header header\ngeometry_msgs/Twist twist"
    + _SEP
    + "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id"
    + _SEP
    + "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular"
    + _SEP
    + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\ngeometry_msgs/Pose pose"
    + _SEP
    + "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id"
    + _SEP
    + "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation"
    + _SEP
    + "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z"
    + _SEP
    + "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    "logcal_test/msg/Mixed": "# every primitive, fixed arrays, sequences, constants\n"
    "int8 A_CONSTANT = 3\nbool flag\nint8 i8\nuint8 u8\nint16 i16\nuint16 u16\nint32 i32\n"
    "uint32 u32\nint64 i64\nuint64 u64\nfloat32 f32\nstring s\nchar c\nfloat32[3] f3\n"
    "bool[] flags\nint16[] shorts\nstring[] words\nfloat64[] values\nuint64 tail",
}
SCHEMAS = {**MSGDEFS, **EXTRA}


def _channel(topic: str = "/t") -> Channel:
    return Channel(id=1, topic=topic, message_encoding="cdr", schema_id=1, metadata={})


def _schema(name: str) -> Schema:
    return Schema(id=1, name=name, encoding="ros2msg", data=SCHEMAS[name].encode())


def _payloads(name: str, messages: list[dict[str, Any]]) -> list[bytes]:
    buf = BytesIO()
    writer = Writer(buf)
    schema = writer.register_msgdef(name, SCHEMAS[name])
    for i, msg in enumerate(messages):
        writer.write_message("/t", schema, msg, log_time=i, publish_time=i)
    writer.finish()
    scan = scan_mcap(buf.getvalue())
    return list(next(iter(scan.messages.values())).payloads)


def _scattered(payloads: list[bytes], seed: int = 0) -> Payloads:
    """The payloads as views into one buffer, with filler bytes between them (as the scan leaves
    them in decompressed chunks); the last one ends the buffer."""
    rng = np.random.default_rng(seed)
    parts: list[bytes] = []
    starts = []
    at = 0
    for p in payloads:
        filler = rng.integers(0, 256, int(rng.integers(0, 40)), dtype=np.uint8).tobytes()
        parts += [filler, p]
        starts.append(at + len(filler))
        at += len(filler) + len(p)
    buffer = np.frombuffer(b"".join(parts), dtype=np.uint8)
    lengths = np.array([len(p) for p in payloads], dtype=np.int64)
    return Payloads(buffer, np.array(starts, dtype=np.int64), lengths)


def _same_as_each(name: str, payloads: list[bytes], *, must_bulk: bool) -> None:
    schema = _schema(name)
    bulk = decode_cdr_bulk(schema, "cdr", payloads)
    if must_bulk:
        assert bulk is not None, f"{name}: the bulk path stepped aside"
    viewed = decode_cdr_bulk(schema, "cdr", _scattered(payloads))
    assert (viewed is None) == (bulk is None)
    if bulk is not None and viewed is not None:
        assert_frame_equal(viewed, bulk, check_exact=True)
    each = decode_cdr_each(schema, _channel(), payloads)
    if bulk is not None:
        assert each.kept is None
        assert_frame_equal(bulk, each.frame, check_exact=True)
    chosen = decode_cdr(schema, _channel(), payloads)
    assert chosen.kept == each.kept
    assert chosen.error == each.error
    assert_frame_equal(chosen.frame, each.frame, check_exact=True)


def _ros2_logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    out = tmp_path_factory.mktemp("ros2")
    made = []
    for robot, extra in (("manipulator", ["--duration", "3"]), ("diff-drive", [])):
        path = out / f"{robot}.mcap"
        cmd = [sys.executable, "-m", "logtools.cli.main", "simulate", robot, "--encoding", "ros2"]
        subprocess.run([*cmd, "-o", str(path), *extra], check=True, capture_output=True)
        made.append(path)
    return made


@pytest.fixture(scope="module")
def ros2_logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return sorted(SAMPLES.glob("*.mcap")) + _ros2_logs(tmp_path_factory)


def test_every_sample_log_bulk_equals_per_message(ros2_logs: list[Path]) -> None:
    bulk_types = set()
    for path in ros2_logs:
        scan = scan_mcap(path.read_bytes())
        for cid, ch in scan.channels.items():
            if ch.message_encoding != "cdr" or cid not in scan.messages:
                continue
            schema = scan.schemas[ch.schema_id]
            payloads = scan.messages[cid].payloads
            bulk = decode_cdr_bulk(schema, "cdr", payloads)
            assert bulk is not None, f"{path.name} {ch.topic}: bulk path stepped aside"
            each = decode_cdr_each(schema, ch, payloads)
            assert each.kept is None
            assert_frame_equal(bulk, each.frame, check_exact=True)
            bulk_types.add(schema.name)
    assert {"nav_msgs/msg/Odometry", "std_msgs/msg/Float64", "sensor_msgs/msg/JointState"} <= (
        bulk_types
    ), bulk_types


_floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
_text = st.text(max_size=12)
_stamp = st.fixed_dictionaries(
    {"sec": st.integers(0, 2**31 - 1), "nanosec": st.integers(0, 2**32 - 1)}
)
_header = st.fixed_dictionaries({"stamp": _stamp, "frame_id": _text})
_vec = st.fixed_dictionaries({"x": _floats, "y": _floats, "z": _floats})
_twist = st.fixed_dictionaries({"linear": _vec, "angular": _vec})
_pose = st.fixed_dictionaries(
    {"position": _vec, "orientation": st.fixed_dictionaries(dict.fromkeys("xyzw", _floats))}
)
_cov = st.lists(_floats, min_size=36, max_size=36)


@st.composite
def _joint_state(draw: st.DrawFn) -> dict[str, Any]:
    n = draw(st.integers(0, 4))
    return {
        "header": draw(_header),
        "name": draw(st.lists(_text, min_size=n, max_size=n)),
        "position": draw(st.lists(_floats, min_size=n, max_size=n)),
        "velocity": draw(st.lists(_floats, max_size=n)),
        "effort": draw(st.lists(_floats, max_size=5)),
    }


_mixed = st.fixed_dictionaries(
    {
        "flag": st.booleans(),
        "i8": st.integers(-128, 127),
        "u8": st.integers(0, 255),
        "i16": st.integers(-(2**15), 2**15 - 1),
        "u16": st.integers(0, 2**16 - 1),
        "i32": st.integers(-(2**31), 2**31 - 1),
        "u32": st.integers(0, 2**32 - 1),
        "i64": st.integers(-(2**63), 2**63 - 1),
        "u64": st.integers(0, 2**64 - 1),
        "f32": st.floats(width=32),
        "s": _text,
        "c": st.integers(-128, 127),
        "f3": st.lists(st.floats(width=32), min_size=3, max_size=3),
        "flags": st.lists(st.booleans(), max_size=3),
        "shorts": st.lists(st.integers(-(2**15), 2**15 - 1), max_size=3),
        "words": st.lists(_text, max_size=3),
        "values": st.lists(_floats, max_size=3),
        "tail": st.integers(0, 2**64 - 1),
    }
)

MESSAGES: dict[str, st.SearchStrategy[dict[str, Any]]] = {
    "std_msgs/msg/Float64": st.fixed_dictionaries({"data": _floats}),
    "std_msgs/msg/Float32": st.fixed_dictionaries({"data": st.floats(width=32)}),
    "geometry_msgs/msg/Twist": _twist,
    "geometry_msgs/msg/TwistStamped": st.fixed_dictionaries({"header": _header, "twist": _twist}),
    "geometry_msgs/msg/PoseStamped": st.fixed_dictionaries({"header": _header, "pose": _pose}),
    "nav_msgs/msg/Odometry": st.fixed_dictionaries(
        {
            "header": _header,
            "child_frame_id": _text,
            "pose": st.fixed_dictionaries({"pose": _pose, "covariance": _cov}),
            "twist": st.fixed_dictionaries({"twist": _twist, "covariance": _cov}),
        }
    ),
    "sensor_msgs/msg/JointState": _joint_state(),
    "logcal_test/msg/Mixed": _mixed,
}


@pytest.mark.slow  # hypothesis: 25 random messages per type
@pytest.mark.parametrize("name", sorted(MESSAGES))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_random_messages_bulk_equals_per_message(name: str, data: st.DataObject) -> None:
    messages = data.draw(st.lists(MESSAGES[name], min_size=1, max_size=8))
    _same_as_each(name, _payloads(name, messages), must_bulk=True)


@pytest.mark.slow  # hypothesis: 25 random messages per type
@pytest.mark.parametrize("name", sorted(MESSAGES))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_damaged_payloads_give_the_per_message_result(name: str, data: st.DataObject) -> None:
    payloads = _payloads(name, data.draw(st.lists(MESSAGES[name], min_size=1, max_size=4)))
    k = data.draw(st.integers(0, len(payloads) - 1))
    raw = bytearray(payloads[k])
    cut = data.draw(st.integers(0, len(raw)))
    if data.draw(st.booleans()):
        raw = raw[:cut]  # truncated
    elif raw:
        raw[min(cut, len(raw) - 1)] = data.draw(st.integers(0, 255))  # one byte changed
    payloads[k] = bytes(raw)
    _same_as_each(name, payloads, must_bulk=False)


def test_unsupported_schemas_step_aside() -> None:
    payload = _payloads("std_msgs/msg/Float64", [{"data": 1.0}])
    for text in ("uint8[] data", "geometry_msgs/Point[] points", "string<=5 data", "wstring w"):
        schema = Schema(id=1, name="x_msgs/msg/T", encoding="ros2msg", data=text.encode())
        assert decode_cdr_bulk(schema, "cdr", payload) is None, text
    big_endian = [b"\x00\x00" + payload[0][2:]]
    assert decode_cdr_bulk(_schema("std_msgs/msg/Float64"), "cdr", big_endian) is None


def test_frame_ids_of_differing_length_in_one_chunk() -> None:
    stamp = {"sec": 1, "nanosec": 2}
    pose = {"position": {"x": 1.0, "y": 2.0, "z": 3.0}, "orientation": dict.fromkeys("xyzw", 0.5)}
    ids = ["", "a", "odom", "base_link_long", "odom", "é"] * 50
    messages = [{"header": {"stamp": stamp, "frame_id": f}, "pose": pose} for f in ids]
    payloads = _payloads("geometry_msgs/msg/PoseStamped", messages)
    assert len({len(p) for p in payloads}) > 1
    _same_as_each("geometry_msgs/msg/PoseStamped", payloads, must_bulk=True)
