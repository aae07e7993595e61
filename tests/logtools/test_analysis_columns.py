"""``load_log`` leaves the covariance matrices out of the raw frames (no estimator reads them),
keeps them when a channel map names one, and resolves the same signals either way."""

from __future__ import annotations

from pathlib import Path

import pytest
from polars.testing import assert_frame_equal

import logtools.load
from logtools.load import analysis_columns, load_log
from logtools.readers import read_log
from logtools.signals import SignalSource

ROS2_LOG = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed_ros2.mcap"


def _covariance(columns: list[str]) -> list[str]:
    return [c for c in columns if ".covariance." in c]


def test_load_log_reads_no_covariance_but_read_log_does() -> None:
    raw = read_log(ROS2_LOG)
    assert _covariance(raw.topics["/odom"].columns)  # the sample carries them
    loaded = load_log(ROS2_LOG)
    for topic, frame in loaded.log.topics.items():
        assert not _covariance(frame.columns)
        others = [c for c in raw.topics[topic].columns if ".covariance." not in c]
        assert frame.columns == others


def test_the_same_signals_with_and_without_covariance(monkeypatch: pytest.MonkeyPatch) -> None:
    lean = load_log(ROS2_LOG)
    monkeypatch.setattr(logtools.load, "analysis_columns", lambda _map=None: None)
    full = load_log(ROS2_LOG)
    assert _covariance(full.log.topics["/odom"].columns)
    assert lean.signals.signals.keys() == full.signals.signals.keys()
    for name, frame in lean.signals.signals.items():
        assert_frame_equal(frame, full.signals.signals[name])
    assert_frame_equal(lean.frame, full.frame)


def test_a_channel_map_naming_a_covariance_keeps_them() -> None:
    keep = analysis_columns({"psi": SignalSource("/odom", "pose.covariance.35")})
    assert keep is None
    drop = analysis_columns({"psi": SignalSource("/hitch/angle", "angle")})
    assert drop is not None
    assert not drop("/odom", "pose.covariance.0")
    assert drop("/odom", "pose.pose.position.x")
    assert drop("/odom", "covariance_note")  # only numbered matrix entries are left out


def test_columns_skipped_while_decoding_equal_columns_dropped_after() -> None:
    """The ROS 2 bulk decoder skips the array items the filter drops (``DROPPED_COLUMNS``);
    the frames equal a full read with those columns selected away."""
    keep = analysis_columns()
    assert keep is not None
    lean = read_log(ROS2_LOG, keep=keep)
    full = read_log(ROS2_LOG)
    for topic, frame in full.topics.items():
        assert_frame_equal(
            lean.topics[topic],
            frame.select([c for c in frame.columns if c == "t_ns" or keep(topic, c)]),
        )
