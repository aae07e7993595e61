"""Writers checked with the mcap library's own readers (independent of logcal's reader)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from calib.tractor_trailer.sim.presets import harmonic
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    SimulatedRun,
    simulate_tractor_trailer,
)
from logtools.errors import LogWriteError
from logtools.readers import read_log
from logtools.writers import (
    CdrEncoder,
    JsonEncoder,
    TopicBinding,
    json_schema,
    msgdef,
    write_frames_mcap,
)
from logtools.writers.tractor_trailer import (
    run_metadata,
    write_csv,
    write_mcap_json,
    write_mcap_ros2,
)

LOG_FORMAT_JSON_FIELDS = {
    "/cmd/curvature": {"curvature"},
    "/cmd/vel": {"v", "omega"},
    "/odom": {"v", "omega"},
    "/pose": {"x", "y", "yaw"},
    "/hitch/angle": {"angle"},
}


@pytest.fixture(scope="module")
def run() -> SimulatedRun:
    eff = Effects(actuator_delay_s=0.2, sensor_offset={"psi": 0.01})
    return simulate_tractor_trailer(harmonic(duration_s=6.0, rate_hz=20.0, effects=eff), seed=5)


def _json_messages(path: Path) -> list[tuple[Any, Any, Any]]:
    with path.open("rb") as fh:
        return list(make_reader(fh).iter_messages(log_time_order=False))


@pytest.mark.parametrize(
    ("compression", "chunked"), [("zstd", True), ("lz4", True), ("none", False)]
)
def test_json_layout_per_log_format(
    run: SimulatedRun, tmp_path: Path, compression: str, chunked: bool
) -> None:
    path = tmp_path / "a.mcap"
    n = write_mcap_json(path, run, compression=compression, chunked=chunked)  # type: ignore[arg-type]
    msgs = _json_messages(path)
    assert n == len(msgs) == sum(f.height for f in run.frames.values()) + run.frames["cmd"].height
    times = [m.log_time for _, _, m in msgs]
    assert times == sorted(times)  # written in time order across topics
    for schema, channel, message in msgs:
        assert channel.message_encoding == "json"
        assert schema.encoding == "jsonschema"
        body = json.loads(message.data)
        assert set(body) == LOG_FORMAT_JSON_FIELDS[channel.topic]
        assert message.publish_time == message.log_time
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    assert (len(summary.chunk_indexes) > 0) is chunked


def test_json_schema_validates_messages(run: SimulatedRun, tmp_path: Path) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    path = tmp_path / "a.mcap"
    write_mcap_json(path, run)
    for schema, _, message in _json_messages(path)[:50]:
        jsonschema.validate(json.loads(message.data), json.loads(schema.data))


def test_metadata_hides_effects_unless_asked(run: SimulatedRun, tmp_path: Path) -> None:
    path = tmp_path / "a.mcap"
    write_mcap_json(path, run)
    with path.open("rb") as fh:
        meta = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}
    assert meta == {"logcal": {"robot": "tractor_trailer", "L1": "1.25", "L2": "2.48", "seed": "5"}}
    full = run_metadata(run, include_effects=True, include_segments=True)
    assert full["logcal"]["actuator_delay_s"] == "0.2"
    assert full["logcal"]["sensor_offset.psi"] == "0.01"
    assert full["logcal.segments"] == {"0": "harmonic 0.0 6.0"}


def test_ros2_messages_decode_with_standard_types(run: SimulatedRun, tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    write_mcap_ros2(path, run)
    got: dict[str, list[Any]] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert channel.message_encoding == "cdr"
            assert schema.encoding == "ros2msg"
            got.setdefault(channel.topic, []).append((schema.name, message.log_time, decoded))
    name, t_ns, odom = got["/odom"][3]
    assert name == "nav_msgs/msg/Odometry"
    assert odom.header.stamp.sec * 10**9 + odom.header.stamp.nanosec == t_ns
    assert odom.twist.twist.linear.x == run.frames["odom"]["v"][3]
    assert odom.twist.twist.angular.z == run.frames["odom"]["omega"][3]
    _, _, pose = got["/pose"][2]
    q = pose.pose.pose.orientation
    yaw = math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z)
    assert yaw == pytest.approx(run.frames["pose"]["yaw"][2], abs=1e-15)
    name, _, twist = got["/cmd/vel"][5]
    assert name == "geometry_msgs/msg/Twist"
    cmd = run.frames["cmd"]
    assert twist.linear.x == cmd["v_cmd"][5]
    assert twist.angular.z == cmd["v_cmd"][5] * cmd["kappa_cmd"][5]
    assert got["/hitch/angle"][0][0] == "std_msgs/msg/Float64"
    assert got["/hitch/angle"][4][2].data == run.frames["hitch"]["psi"][4]


def test_msgdef_concatenates_dependencies_like_rosbag2() -> None:
    text = msgdef("geometry_msgs/msg/Twist")
    sep = "=" * 80
    assert text == (
        "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"
        f"{sep}\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z"
    )
    odom = msgdef("nav_msgs/msg/Odometry")
    # Header, Time, PoseWithCovariance, Pose, Point, Quaternion, TwistWithCovariance, Twist,
    # Vector3: each dependency once.
    assert odom.count("MSG: ") == 9


def test_generic_writer_other_robot_and_nan(tmp_path: Path) -> None:
    """A binding for another robot's topic (/wheels); NaN is written as JSON null."""
    frames = {
        "wheels": pl.DataFrame(
            {"t_ns": [10, 20, 30], "wheel_left": [0.0, np.nan, 2.0], "wheel_right": [1.0, 2, 3]}
        )
    }
    binding = TopicBinding(
        "/wheels", "wheels", "logcal/Wheels", {"left": "wheel_left", "right": "wheel_right"}
    )
    path = tmp_path / "w.mcap"
    assert write_frames_mcap(path, frames, [binding], JsonEncoder(), metadata={}) == 3
    bodies = [json.loads(m.data) for _, _, m in _json_messages(path)]
    assert bodies == [
        {"left": 0.0, "right": 1.0},
        {"left": None, "right": 2.0},
        {"left": 2.0, "right": 3.0},
    ]
    assert json_schema(binding)["properties"]["left"] == {"type": ["number", "null"]}


def test_one_writer_two_encoders_same_values(tmp_path: Path) -> None:
    """The same frames through the JSON and the CDR encoder read back alike; CDR keeps NaN as a
    float (JSON writes null, which the reader turns into a missing value)."""
    frames = {"hitch": pl.DataFrame({"t_ns": [10, 20, 30], "psi": [0.25, np.nan, -0.5]})}
    ros2 = TopicBinding("/hitch/angle", "hitch", "std_msgs/msg/Float64", {"data": "psi"})
    json_b = TopicBinding("/hitch/angle", "hitch", "logcal/JointAngle", {"data": "psi"})
    assert write_frames_mcap(tmp_path / "c.mcap", frames, [ros2], CdrEncoder()) == 3
    assert write_frames_mcap(tmp_path / "j.mcap", frames, [json_b], JsonEncoder()) == 3
    cdr = read_log(tmp_path / "c.mcap")
    jsn = read_log(tmp_path / "j.mcap")
    assert cdr.info["/hitch/angle"].message_encoding == "cdr"
    assert jsn.info["/hitch/angle"].message_encoding == "json"
    c = cdr.topics["/hitch/angle"]
    j = jsn.topics["/hitch/angle"]
    assert c["t_ns"].to_list() == j["t_ns"].to_list() == [10, 20, 30]
    assert c["data"].to_list()[0::2] == j["data"].to_list()[0::2] == [0.25, -0.5]
    assert np.isnan(c["data"][1])
    assert j["data"][1] is None


def test_writer_errors_name_what_is_wrong(run: SimulatedRun, tmp_path: Path) -> None:
    bad = TopicBinding("/odom", "odom", "x", {"v": "speed"})
    with pytest.raises(LogWriteError, match=r"topic '/odom': frame 'odom' has no column 'speed'"):
        write_frames_mcap(tmp_path / "x.mcap", run.frames, [bad], JsonEncoder())
    with pytest.raises(LogWriteError, match="cannot write"):
        write_mcap_json(tmp_path / "no" / "dir" / "x.mcap", run)
    with pytest.raises(LogWriteError, match="cannot write"):
        write_csv(tmp_path / "no" / "x.csv", run)


def test_csv_rows_union_with_empty_cells(run: SimulatedRun, tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    rows = write_csv(path, run)
    lines = path.read_text().splitlines()
    assert lines[0] == "t,kappa_cmd,v_cmd,omega_cmd,v,omega,x,y,yaw,psi"
    assert rows == len(lines) - 1 == run.frames["cmd"].height
    # the pose runs at half rate: every other row has empty x, y, yaw
    assert lines[2].split(",")[6:9] == ["", "", ""]
    assert lines[1].split(",")[0] == "0.0"
