"""ROS bags read directly (rosbags): a Foxy rosbag2 with sqlite3 storage and no type definitions,
a rosbag2 with mcap storage and a ROS 1 .bag, all written into tmp_path by rosbags or by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest
from bagmaker import RATES, T0_NS, TYPES, Drive, write_foxy_db3, write_ros1, write_rosbag2

from logtools.channel_map import resolve_signals
from logtools.errors import LogcalInputError, NotAnMcapError, NotARosbagError
from logtools.readers import read_log

FORMATS = {
    "foxy_db3": lambda p, d: write_foxy_db3(p / "foxy_bag", d),
    "rosbag2_mcap": lambda p, d: write_rosbag2(p / "mcap_bag", d, "mcap"),
    "rosbag2_db3": lambda p, d: write_rosbag2(p / "db3_bag", d, "sqlite3"),
    "ros1_bag": lambda p, d: write_ros1(p / "drive.bag", d),
}


@pytest.fixture(params=sorted(FORMATS))
def bag(request: pytest.FixtureRequest, tmp_path: Path) -> tuple[str, Path, Drive]:
    drive = Drive(duration_s=20.0)
    return request.param, FORMATS[request.param](tmp_path, drive), drive


def test_every_format_gives_the_same_frames(bag: tuple[str, Path, Drive]) -> None:
    kind, path, drive = bag
    log = read_log(path)
    assert log.problems == []
    assert sorted(log.topics) == sorted(RATES)
    for topic, msgtype in TYPES.items():
        info = log.info[topic]
        assert info.schema_name == msgtype
        assert info.message_encoding == ("ros1" if kind == "ros1_bag" else "cdr")
        assert info.message_count == len(drive.times[topic]) == log.topics[topic].height
        expected_t = T0_NS + np.round(drive.times[topic] * 1e9).astype(np.int64)
        np.testing.assert_array_equal(log.topics[topic]["t_ns"].to_numpy(), expected_t)
    # Foxy stores no message definitions: the types come from rosbags' Foxy type store
    encoding = {"foxy_db3": "", "ros1_bag": "ros1msg"}.get(kind, "ros2msg")
    assert log.info["/odom"].schema_encoding == encoding
    psi = log.topics["/encoder/angle"]["data"].to_numpy()
    np.testing.assert_allclose(psi, drive.psi(drive.times["/encoder/angle"]), atol=1e-7)  # f32
    cmd = log.topics["/cmd_vel"]
    steer = drive.steer(drive.times["/cmd_vel"])
    np.testing.assert_array_equal(cmd["angular.z"].to_numpy(), steer)
    odom = log.topics["/odom"]
    assert odom["twist.twist.linear.x"].abs().max() == 0.0
    assert "pose.covariance.35" in odom.columns
    tf = log.topics["/tf"]
    assert {"transforms.0.child_frame_id", "transforms.1.transform.rotation.w"} <= set(tf.columns)
    stamp = odom["header.stamp.sec"].cast(pl.Int64) * 10**9 + odom["header.stamp.nanosec"]
    np.testing.assert_array_equal(stamp.to_numpy(), odom["t_ns"].to_numpy())
    # the standard ROS names are defaults; the all-zero twist is found and not used
    res = resolve_signals(log)
    assert {(f.name, f.topic, f.field) for f in res.flat} == {
        ("v", "/odom", "twist.twist.linear.x"),
        ("omega", "/odom", "twist.twist.angular.z"),
    }
    assert {"x", "y", "yaw", "v_cmd", "omega_cmd"} <= set(res.signals)
    assert not {"v", "omega"} & set(res.signals)


def test_rosbag2_mcap_equals_the_mcap_reader(tmp_path: Path) -> None:
    """rosbags on the folder and logcal's MCAP reader on the folder's .mcap file agree."""
    path = write_rosbag2(tmp_path / "bag", Drive(duration_s=5.0))
    via_rosbags = read_log(path)
    via_mcap = read_log(next(path.glob("*.mcap")))
    assert sorted(via_rosbags.topics) == sorted(via_mcap.topics)
    for topic, frame in via_rosbags.topics.items():
        assert frame.equals(via_mcap.topics[topic]), topic
        assert via_rosbags.info[topic] == via_mcap.info[topic]


def test_db3_file_reads_its_folder_and_topics_can_be_chosen(tmp_path: Path) -> None:
    path = write_foxy_db3(tmp_path / "foxy", Drive(duration_s=5.0))
    whole = read_log(path)
    db3 = read_log(next(path.glob("*.db3")))
    assert sorted(db3.topics) == sorted(whole.topics)
    some = read_log(path, topics=["/cmd_vel"])
    assert list(some.topics) == ["/cmd_vel"]
    assert sorted(some.info) == sorted(RATES)
    assert some.info["/odom"].message_count == whole.info["/odom"].message_count


def test_custom_data_becomes_the_logcal_metadata_record(tmp_path: Path) -> None:
    custom = {"logcal.robot": "tractor_trailer", "logcal.wheelbase": "0.42", "site": "lab"}
    log = read_log(write_rosbag2(tmp_path / "bag", Drive(duration_s=3.0), custom=custom))
    assert log.metadata["logcal"] == {"robot": "tractor_trailer", "wheelbase": "0.42"}
    assert log.metadata["rosbag2"]["custom_data.site"] == "lab"


def test_bad_bags_give_one_clear_error(tmp_path: Path) -> None:
    folder = tmp_path / "broken"
    folder.mkdir()
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 4\n")
    with pytest.raises(NotARosbagError, match=r"broken: not a readable ROS bag .*metadata"):
        read_log(folder)
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"not a bag at all" * 10)
    with pytest.raises(NotARosbagError, match=r"junk\.bag: not a readable ROS bag"):
        read_log(junk)
    empty_dir = tmp_path / "empty"
    empty_dir.mkdir()
    with pytest.raises(NotAnMcapError, match=r"directory without a rosbag2 metadata\.yaml"):
        read_log(empty_dir)
    assert issubclass(NotARosbagError, LogcalInputError)
