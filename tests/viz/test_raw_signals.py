"""Every robot's recording holds the signals as read (before alignment) under ``/raw``, each
topic's fields at that topic's own stamps, beside the fit."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

from logtools.cli.main import main
from logtools.readers import read_log

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"


def _raw_rows(rrd: Path) -> Counter[str]:
    """Rows per entity under /raw in the first recording of ``rrd``."""
    rows: Counter[str] = Counter()
    for chunk in RrdReader(rrd).stream().to_chunks():
        if chunk.entity_path.startswith("/raw/") and not chunk.is_static:
            rows[chunk.entity_path] += chunk.to_record_batch().num_rows
    return rows


def _log(robot: str, tmp_path: Path) -> Path:
    if robot == "tractor_trailer":
        return SAMPLES / "tt_harmonic_clean.mcap"
    out = tmp_path / f"{robot}.mcap"
    cmd = {
        "diff_drive": ["simulate", "diff-drive", "--out", str(out)],
        "manipulator": ["simulate", "manipulator", "--out", str(out), "--duration", "6"],
    }
    assert main(cmd[robot]) == 0
    return out


@pytest.mark.parametrize("robot", ["tractor_trailer", "diff_drive", "manipulator"])
def test_recording_holds_the_signals_as_read(robot: str, tmp_path: Path) -> None:
    log = _log(robot, tmp_path)
    rrd = tmp_path / "out.rrd"
    assert (
        main(
            [
                "analyze",
                str(log),
                "--no-discovery",
                "--repeats",
                "1",
                "--rrd",
                str(rrd),
                "--png",
                str(tmp_path / "out.png"),
            ]
        )
        == 0
    )
    rows = _raw_rows(rrd)
    assert rows, "no /raw entity in the recording"
    data = read_log(log)
    # one numeric field of each topic, at every message the topic recorded
    for topic, frame in data.topics.items():
        fields = [
            c
            for c, t in frame.schema.items()
            if c != "t_ns" and t.is_numeric() and "covariance" not in c
        ]
        if not fields:
            continue
        path = "/raw/" + "/".join(p for p in topic.split("/") if p) + "/" + fields[0]
        hits = [k for k in rows if k.replace("\\", "") == path]
        assert hits, (path, sorted(rows)[:10])
        assert rows[hits[0]] == frame.height


def test_raw_series_are_grouped_one_axis_per_unit() -> None:
    """Metres and rad/s never share a plot (x, y up to 70 m beside rad/s flattened them)."""
    import polars as pl

    from viz.raw import raw_groups

    t = [0, 1]
    topics = {
        "/pose": pl.DataFrame({"t_ns": t, "x": [0.0, 70.0], "y": [0.0, 1.0], "yaw": [0.0, 0.1]}),
        "/odom": pl.DataFrame(
            {
                "t_ns": t,
                "twist.twist.linear.x": [1.0, 1.0],
                "twist.twist.angular.z": [0.1, 0.2],
                "pose.pose.position.x": [0.0, 1.0],
            }
        ),
    }
    groups = raw_groups(topics)
    assert groups == {
        "/odom (m/s)": ["raw/odom/twist.twist.linear.x"],
        "/odom (rad/s)": ["raw/odom/twist.twist.angular.z"],
        "/odom (m)": ["raw/odom/pose.pose.position.x"],
        "/pose (m)": ["raw/pose/x", "raw/pose/y"],
        "/pose (rad)": ["raw/pose/yaw"],
    }
