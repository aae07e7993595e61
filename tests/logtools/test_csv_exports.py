"""CSV exports of PlotJuggler, Foxglove and ``ros2 bag`` tools read with zero configuration
(issue 33, item 6): columns named by ROS paths (``/odom/twist/twist/linear/x``) become their
topics and fields, which the default channel map finds as in an MCAP file; ``info`` lists every
topic's fields."""

from __future__ import annotations

import json
import math
from pathlib import Path

from logtools.cli.main import main
from logtools.readers import read_log
from logtools.readers.csv_reader import topic_field

HEADER = (
    "__time,/odom/twist/twist/linear/x,/odom/twist/twist/angular/z,/hitch/angle/data,"
    "/pose/pose/pose/position/x,/pose/pose/pose/position/y,/pose/pose/pose/orientation/x,"
    "/pose/pose/pose/orientation/y,/pose/pose/pose/orientation/z,/pose/pose/pose/orientation/w,"
    "battery"
)


def _export(path: Path) -> Path:
    """A PlotJuggler-like export: 20 Hz odometry and joint angle, 10 Hz pose on every other
    row (the other rows' cells empty), and a column with no topic."""
    rows = [HEADER]
    for i in range(100):
        t = 1_700_000_000.0 + 0.05 * i
        yaw = 0.01 * i
        pose = (
            f"{0.05 * i},{0.001 * i},0,0,{math.sin(yaw / 2):.6f},{math.cos(yaw / 2):.6f}"
            if i % 2 == 0
            else ",,,,,"
        )
        rows.append(f"{t:.3f},1.0,0.1,{0.05 * math.sin(i / 10):.5f},{pose},12.0")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_a_ros_path_column_is_a_topic_and_a_field() -> None:
    assert topic_field("/odom/twist/twist/linear/x") == ("/odom", "twist.twist.linear.x")
    assert topic_field("/hitch/angle/data") == ("/hitch/angle", "data")
    assert topic_field("/pose/pose/pose/position/x") == ("/pose", "pose.pose.position.x")
    assert topic_field("/wheels/position[1]") == ("/wheels", "position.1")
    assert topic_field("/speed") is None
    assert topic_field("psi") is None


def test_an_export_reads_as_topics(tmp_path) -> None:
    log = read_log(_export(tmp_path / "pj.csv"))
    assert set(log.topics) == {"/odom", "/hitch/angle", "/pose", "csv"}
    assert log.topics["/odom"].columns == ["t_ns", "twist.twist.linear.x", "twist.twist.angular.z"]
    assert log.info["/odom"].message_count == 100
    assert log.info["/pose"].message_count == 50  # the rows where the pose has values
    assert log.topics["csv"].columns == ["t_ns", "battery"]


def test_info_finds_the_signals_and_lists_the_fields(tmp_path, capsys) -> None:
    path = _export(tmp_path / "pj.csv")
    assert main(["info", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    found = {n: (s["topic"], s["field"]) for n, s in doc["signals"].items()}
    assert found["v"] == ("/odom", "twist.twist.linear.x")
    assert found["omega"] == ("/odom", "twist.twist.angular.z")
    assert found["psi"] == ("/hitch/angle", "data")
    assert found["yaw"] == ("/pose", "pose.pose.orientation")
    assert doc["robot"] == "tractor_trailer"
    fields = {t["topic"]: t["fields"] for t in doc["topics"]}
    assert fields["/hitch/angle"] == ["data"]
    assert fields["csv"] == ["battery"]
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "    fields: twist.twist.linear.x, twist.twist.angular.z" in text


def test_a_plain_csv_stays_one_topic(tmp_path) -> None:
    path = tmp_path / "plain.csv"
    path.write_text("t,v,omega,psi\n0,1,0,0\n0.1,1,0,0.01\n", encoding="utf-8")
    log = read_log(path)
    assert list(log.topics) == ["csv"]
    assert log.topics["csv"].columns == ["t_ns", "v", "omega", "psi"]
