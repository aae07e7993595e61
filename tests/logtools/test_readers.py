"""read_log over every encoding and MCAP layout, checked against the values that were written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from mcap.writer import Writer

from logtools.readers import CSV_TOPIC, LogData, ProblemKind, read_log

LAYOUTS = [
    pytest.param(chunked, compression, summary, id=f"{c_id}-{compression}-{s_id}")
    for chunked, c_id in ((True, "chunked"), (False, "unchunked"))
    for compression in ("zstd", "lz4", "none")
    for summary, s_id in ((True, "summary"), (False, "nosummary"))
    if chunked or compression == "none"  # compression applies to chunks only
]


@pytest.mark.parametrize(("chunked", "compression", "summary"), LAYOUTS)
def test_json_layouts_read_exact_values(
    tmp_path, truth, mcap_writers, chunked, compression, summary
):
    path = mcap_writers.json(
        tmp_path / "log.mcap",
        truth,
        chunked=chunked,
        compression=compression,
        summary=summary,
        metadata={"robot": "tractor_trailer", "L1": "1.2"},
    )
    log = read_log(path)
    assert log.problems == []
    assert log.topic_names() == ["/cmd/curvature", "/hitch/angle", "/odom", "/pose"]
    assert log.metadata == {"logcal": {"robot": "tractor_trailer", "L1": "1.2"}}
    pose = log.topics["/pose"]
    assert pose["t_ns"].dtype == pl.Int64
    np.testing.assert_array_equal(pose["t_ns"].to_numpy(), truth["t_ns"])
    for column in ("x", "y", "yaw"):
        np.testing.assert_array_equal(pose[column].to_numpy(), truth[column])
    np.testing.assert_array_equal(log.topics["/hitch/angle"]["angle"].to_numpy(), truth["psi"])
    info = log.info["/odom"]
    assert (info.message_count, info.first_ns, info.last_ns) == (
        200,
        truth["t_ns"][0],
        truth["t_ns"][-1],
    )
    assert info.schema_encoding == "jsonschema"
    assert info.message_encoding == "json"
    assert info.rate_hz == pytest.approx(50.0)


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_ros2_standard_types_flattened_by_path(tmp_path, truth, mcap_writers, compression):
    log = read_log(mcap_writers.ros2(tmp_path / "ros2.mcap", truth, compression=compression))
    assert log.problems == []
    odom = log.topics["/odom"]
    np.testing.assert_array_equal(odom["twist.twist.linear.x"].to_numpy(), truth["v"])
    np.testing.assert_array_equal(odom["twist.twist.angular.z"].to_numpy(), truth["omega"])
    assert "pose.covariance.35" in odom.columns  # fixed arrays become numbered columns
    assert odom["header.frame_id"][0] == "odom"
    wheels = log.topics["/wheels"]
    assert wheels["name.0"][0] == "left"
    np.testing.assert_array_equal(wheels["position.1"].to_numpy(), 12.0 * truth["x"])
    assert log.info["/odom"].schema_name == "nav_msgs/msg/Odometry"


def test_topics_argument_decodes_only_those(tmp_path, truth, mcap_writers):
    log = read_log(mcap_writers.json(tmp_path / "log.mcap", truth), topics=["/odom"])
    assert list(log.topics) == ["/odom"]
    assert len(log.info) == 4  # the others are still described


def _pb_class():
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    F = descriptor_pb2.FieldDescriptorProto
    fdp = descriptor_pb2.FileDescriptorProto(
        name="logcal_test_hitch.proto", package="logcal_test", syntax="proto3"
    )
    vec = fdp.message_type.add(name="Vec")
    vec.field.add(name="x", number=1, type=F.TYPE_DOUBLE, label=F.LABEL_OPTIONAL)
    hitch = fdp.message_type.add(name="Hitch")
    hitch.field.add(name="angle", number=1, type=F.TYPE_DOUBLE, label=F.LABEL_OPTIONAL)
    hitch.field.add(
        name="offset",
        number=2,
        type=F.TYPE_MESSAGE,
        label=F.LABEL_OPTIONAL,
        type_name=".logcal_test.Vec",
    )
    hitch.field.add(name="samples", number=3, type=F.TYPE_DOUBLE, label=F.LABEL_REPEATED)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fdp)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("logcal_test.Hitch"))


def test_protobuf(tmp_path, truth):
    from mcap_protobuf.writer import Writer as PbWriter

    cls = _pb_class()
    path = tmp_path / "pb.mcap"
    with path.open("wb") as fh:
        w = PbWriter(fh)
        for i, t in enumerate(truth["t_ns"]):
            msg = cls(angle=truth["psi"][i], samples=[float(i), 2.0 * i])
            msg.offset.x = truth["x"][i]
            w.write_message("/hitch/angle", msg, log_time=int(t), publish_time=int(t))
        w.finish()
    log = read_log(path)
    frame = log.topics["/hitch/angle"]
    np.testing.assert_array_equal(frame["angle"].to_numpy(), truth["psi"])
    np.testing.assert_array_equal(frame["offset.x"].to_numpy(), truth["x"])
    np.testing.assert_array_equal(frame["samples.1"].to_numpy(), 2.0 * np.arange(200))
    assert log.info["/hitch/angle"].message_encoding == "protobuf"


def test_ros1(tmp_path, truth):
    from mcap_ros1._vendor.genpy.dynamic import generate_dynamic
    from mcap_ros1.writer import Writer as Ros1Writer

    cls = generate_dynamic("logcal_test/Hitch", "float64 angle\nfloat64[] samples\ntime stamp")[
        "logcal_test/Hitch"
    ]
    path = tmp_path / "ros1.mcap"
    with path.open("wb") as fh:
        w = Ros1Writer(fh)
        for i, t in enumerate(truth["t_ns"]):
            w.write_message(
                "/hitch/angle", cls(angle=truth["psi"][i], samples=[1.0, float(i)]), int(t)
            )
        w.finish()
    frame = read_log(path).topics["/hitch/angle"]
    np.testing.assert_array_equal(frame["angle"].to_numpy(), truth["psi"])
    np.testing.assert_array_equal(frame["samples.1"].to_numpy(), np.arange(200.0))
    assert "stamp.secs" in frame.columns


def _write_raw_json(path: Path, messages: list[tuple[int, bytes]], topic: str = "/j") -> Path:
    with path.open("wb") as fh:
        w = Writer(fh, chunk_size=256)
        w.start()
        ch = w.register_channel(topic, "json", w.register_schema("j", "jsonschema", b"{}"))
        for t, data in messages:
            w.add_message(ch, t, data, t)
        w.finish()
    return path


def test_json_nested_objects_and_arrays_flatten(tmp_path):
    msgs = [
        (i, json.dumps({"position": [i, 2 * i], "inner": {"a": i, "b": {"c": -i}}}).encode())
        for i in range(1, 4)
    ]
    frame = read_log(_write_raw_json(tmp_path / "n.mcap", msgs)).topics["/j"]
    assert frame.columns == ["t_ns", "position.0", "position.1", "inner.a", "inner.b.c"]
    assert frame["position.1"].to_list() == [2, 4, 6]
    assert frame["inner.b.c"].to_list() == [-1, -2, -3]


def test_json_pretty_printed_and_undecodable_messages(tmp_path):
    msgs = [(1, b'{\n  "v": 1.0\n}'), (2, b'{"v": 2.0}'), (3, b"{broken"), (4, b'{"v": 4.0}')]
    log = read_log(_write_raw_json(tmp_path / "p.mcap", msgs))
    assert log.topics["/j"]["v"].to_list() == [1.0, 2.0, 4.0]
    assert log.topics["/j"]["t_ns"].to_list() == [1, 2, 4]
    (dropped,) = log.problems
    assert (dropped.kind, dropped.topic, dropped.count) == (ProblemKind.DROPPED_MESSAGES, "/j", 1)
    assert (dropped.t0_ns, dropped.t1_ns) == (1, 4)


def test_log_time_going_backwards_is_sorted_and_reported(tmp_path):
    msgs = [(t, json.dumps({"v": float(t)}).encode()) for t in (10, 30, 20, 40)]
    log = read_log(_write_raw_json(tmp_path / "b.mcap", msgs))
    assert log.topics["/j"]["t_ns"].to_list() == [10, 20, 30, 40]
    assert log.topics["/j"]["v"].to_list() == [10.0, 20.0, 30.0, 40.0]
    assert [(p.kind, p.topic, p.count) for p in log.problems] == [(ProblemKind.UNSORTED, "/j", 1)]


def test_csv(tmp_path):
    path = tmp_path / "drive.csv"
    path.write_text("t,kappa_cmd,psi,q1,note\n0.0,0.1,0.05,1,a\n0.02,0.1,,2,b\n,0.3,0.2,3,c\n")
    log = read_log(path)
    assert isinstance(log, LogData)
    frame = log.topics[CSV_TOPIC]
    assert frame["t_ns"].to_list() == [0, 20_000_000]
    assert frame["psi"].to_list() == [0.05, None]
    assert log.info[CSV_TOPIC].message_count == 2
    assert [(p.kind, p.count) for p in log.problems] == [(ProblemKind.NO_TIME, 1)]


def test_csv_detected_without_suffix(tmp_path):
    path = tmp_path / "drive.txt"
    path.write_text("t,psi\n0,0.1\n1,0.2\n")
    assert read_log(path).topics[CSV_TOPIC]["t_ns"].to_list() == [0, 1_000_000_000]
