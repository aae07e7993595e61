"""Bad input: a clear LogcalInputError (exit 2, no traceback) or a repair listed in problems."""

from __future__ import annotations

import json
import math

import numpy as np
import polars as pl
import pytest
from mcap.writer import Writer

from logtools.channel_map import resolve_signals
from logtools.cli.main import main
from logtools.errors import (
    LogcalInputError,
    LogFileNotFoundError,
    NotAnMcapError,
    SignalValueError,
    TimestampError,
    UnknownEncodingError,
)
from logtools.readers import DEFAULT_DECODERS, ProblemKind, read_log
from logtools.readers.decoders import Decoded


def _write(path, messages, topic="/hitch/angle", encoding="json"):
    """messages: (log_time ns, JSON-able dict or raw bytes)."""
    with path.open("wb") as fh:
        w = Writer(fh, chunk_size=512)
        w.start()
        ch = w.register_channel(topic, encoding, w.register_schema("s", "jsonschema", b"{}"))
        for t, msg in messages:
            data = msg if isinstance(msg, bytes) else json.dumps(msg).encode()
            w.add_message(ch, t, data, t)
        w.finish()
    return path


def test_missing_file(tmp_path):
    with pytest.raises(LogFileNotFoundError, match="no such file"):
        read_log(tmp_path / "absent.mcap")


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"", "the file is empty"),
        (b"\x89MCA", "only 4 bytes of an MCAP header"),
        (b"PK\x03\x04 a zip file, not a log", "it starts with the bytes"),
        (bytes(range(256)) * 4, "it starts with the bytes"),
    ],
)
def test_not_an_mcap(tmp_path, content, needle):
    path = tmp_path / "x.mcap"
    path.write_bytes(content)
    with pytest.raises(NotAnMcapError, match=needle):
        read_log(path)


def test_directory_and_csv_without_time(tmp_path):
    with pytest.raises(NotAnMcapError, match="is a directory"):
        read_log(tmp_path)
    path = tmp_path / "x.csv"
    path.write_text("time,psi\n0,1\n")
    with pytest.raises(NotAnMcapError, match="no time column 't'; its columns: time, psi"):
        read_log(path)


def test_nan_and_inf_dropped_with_count(tmp_path):
    values = [0.1, math.nan, 0.2, math.inf, 0.3, -math.inf]
    log = read_log(_write(tmp_path / "n.mcap", [(i, {"angle": v}) for i, v in enumerate(values)]))
    res = resolve_signals(log)
    assert res.signals["psi"]["value"].to_list() == [0.1, 0.2, 0.3]
    assert res.signals["psi"]["t_ns"].to_list() == [0, 2, 4]
    assert any("3 NaN/inf values of 6 were dropped" in p for p in res.problems)


def test_all_nan_signal_is_an_error(tmp_path):
    log = read_log(_write(tmp_path / "n.mcap", [(i, {"angle": math.nan}) for i in range(4)]))
    with pytest.raises(SignalValueError, match=r"topic '/hitch/angle', field 'angle'.*all 4"):
        resolve_signals(log)


def test_duplicate_and_decreasing_timestamps_sorted_and_deduplicated(tmp_path):
    msgs = [(0, {"angle": 0.0}), (2, {"angle": 0.2}), (1, {"angle": 0.1}), (2, {"angle": 0.25})]
    log = read_log(_write(tmp_path / "d.mcap", msgs))
    assert [(p.kind, p.count) for p in log.problems] == [(ProblemKind.UNSORTED, 1)]
    res = resolve_signals(log)
    assert res.signals["psi"]["t_ns"].to_list() == [0, 1, 2]
    assert res.signals["psi"]["value"].to_list() == [0.0, 0.1, 0.2]  # first of the repeats
    assert any("1 samples repeated a timestamp" in p for p in res.problems)


def test_one_timestamp_for_all_samples_is_an_error(tmp_path):
    log = read_log(_write(tmp_path / "s.mcap", [(5, {"angle": 0.1 * i}) for i in range(3)]))
    with pytest.raises(TimestampError, match="all 3 samples have the same timestamp"):
        resolve_signals(log)


def test_psi_in_degrees(tmp_path):
    msgs = [(i, {"angle": 30.0 * math.sin(0.1 * i)}) for i in range(50)]
    log = read_log(_write(tmp_path / "deg.mcap", msgs))
    with pytest.raises(SignalValueError, match=r"topic '/hitch/angle', field 'angle'.*degrees"):
        resolve_signals(log)


def _pose_odom_log(path, yaw, omega):
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        pose, odom = (
            w.register_channel("/pose", "json", sid),
            w.register_channel("/odom", "json", sid),
        )
        for i, (a, b) in enumerate(zip(yaw, omega, strict=True)):
            t = i * 100_000_000  # 10 Hz
            w.add_message(pose, t, json.dumps({"x": 0.0, "y": 0.0, "yaw": float(a)}).encode(), t)
            w.add_message(odom, t, json.dumps({"v": 1.0, "omega": float(b)}).encode(), t)
        w.finish()
    return path


def test_unwrapped_yaw_in_radians_is_accepted(tmp_path):
    t = np.arange(300) * 0.1
    yaw = 0.5 * t  # 15 rad: more than two turns, consistent with omega = 0.5 rad/s
    res = resolve_signals(read_log(_pose_odom_log(tmp_path / "u.mcap", yaw, 0.5 + 0 * t)))
    np.testing.assert_array_equal(res.signals["yaw"]["value"].to_numpy(), yaw)
    assert res.problems == []
    # without a yaw rate to compare with, the assumption is stated
    res = resolve_signals(read_log(_pose_odom_log(tmp_path / "z.mcap", yaw, 0 * t)))
    assert any("taken as an unwrapped yaw in radians" in p for p in res.problems)


def test_yaw_in_degrees_found_by_its_rate(tmp_path):
    t = np.arange(300) * 0.1
    omega = 0.2 * np.cos(0.2 * t)  # never wraps: |yaw| stays below 60 degrees
    yaw_deg = np.degrees(np.sin(0.2 * t))
    log = read_log(_pose_odom_log(tmp_path / "d.mcap", yaw_deg, omega))
    with pytest.raises(SignalValueError, match=r"field 'yaw'.*57 times faster than omega"):
        resolve_signals(log)


def test_yaw_in_degrees_found_by_its_wrap(tmp_path):
    t = np.arange(300) * 0.1
    yaw_deg = (np.degrees(0.5 * t) + 180) % 360 - 180
    log = read_log(
        _write(tmp_path / "w.mcap", [(i, {"yaw": v}) for i, v in enumerate(yaw_deg)], topic="/pose")
    )
    with pytest.raises(SignalValueError, match=r"topic '/pose', field 'yaw'.*wraps around by"):
        resolve_signals(log)


def test_unknown_encoding(tmp_path):
    path = _write(tmp_path / "u.mcap", [(1, b"\xa1\x61a\x01")], encoding="cbor")
    with pytest.raises(UnknownEncodingError, match=r"'/hitch/angle' uses message encoding 'cbor'"):
        read_log(path)


def test_unknown_encoding_on_one_topic_is_a_problem_until_a_signal_needs_it(tmp_path):
    path = tmp_path / "mixed.mcap"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        good = w.register_channel("/odom", "json", sid)
        bad = w.register_channel("/hitch/angle", "cbor", sid)
        for i in range(3):
            w.add_message(good, i, json.dumps({"v": 1.0, "omega": 0.1}).encode(), i)
            w.add_message(bad, i, b"\x01", i)
        w.finish()
    log = read_log(path)
    assert "/hitch/angle" in log.info
    assert "/hitch/angle" not in log.topics
    (problem,) = log.problems
    assert (problem.kind, problem.topic, problem.count) == (
        ProblemKind.UNKNOWN_ENCODING,
        "/hitch/angle",
        3,
    )
    with pytest.raises(UnknownEncodingError) as info:
        resolve_signals(log)
    assert info.value.topic == "/hitch/angle"

    # a decoder passed in for this read decodes it; the defaults are left as they were
    def decode_cbor(schema, channel, payloads):
        return Decoded(pl.DataFrame({"angle": [float(p[0]) for p in payloads]}))

    log = read_log(path, decoders={**DEFAULT_DECODERS, "cbor": decode_cbor})
    assert log.problems == []
    assert log.topics["/hitch/angle"]["angle"].to_list() == [1.0, 1.0, 1.0]
    assert "cbor" not in DEFAULT_DECODERS


def test_cli_bad_input_exit_2_without_traceback(tmp_path, capsys):
    assert main(["info", str(tmp_path / "absent.mcap")]) == 2
    err = capsys.readouterr().err
    assert "no such file" in err
    assert "Traceback" not in err
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"garbage!" * 10)
    assert main(["--debug", "info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err
    assert "NotAnMcapError" in err


def test_cli_degrees_error_names_topic_and_field(tmp_path, capsys):
    msgs = [(i, {"angle": float(v)}) for i, v in enumerate(np.linspace(-40, 40, 20))]
    assert main(["info", str(_write(tmp_path / "deg.mcap", msgs))]) == 2
    err = capsys.readouterr().err
    assert "topic '/hitch/angle', field 'angle'" in err
    assert "degrees" in err


def test_schema_that_does_not_parse(tmp_path):
    path = tmp_path / "schema.mcap"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64[[ data !!")
        ch = w.register_channel("/hitch/angle", "cdr", sid)
        for i in range(3):
            w.add_message(ch, i, b"\x00\x01\x00\x00" + bytes(8), i)
        w.finish()
    log = read_log(path)
    (problem,) = log.problems
    assert (problem.kind, problem.topic, problem.count) == (
        ProblemKind.UNDECODABLE,
        "/hitch/angle",
        3,
    )
    with pytest.raises(LogcalInputError, match=r"'/hitch/angle' \(std_msgs/msg/Float64, cdr\)"):
        resolve_signals(log)
