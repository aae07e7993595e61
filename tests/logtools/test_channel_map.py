"""Logical signals from default names, ROS 2 types, CSV columns and channel maps; robot type."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from mcap.writer import Writer

from logtools.channel_map import load_channel_map, resolve_signals
from logtools.errors import ChannelMapError, LogcalInputError, NoDriveSignalsError
from logtools.readers import read_log
from logtools.robot import explain_robot, infer_robot
from logtools.signals import SignalSource

DRIVE = ("kappa_cmd", "v", "omega", "x", "y", "yaw", "psi")


def test_json_defaults(tmp_path, truth, mcap_writers):
    log = read_log(mcap_writers.json(tmp_path / "j.mcap", truth))
    res = resolve_signals(log)
    assert set(res.signals) == set(DRIVE)
    for name in DRIVE:
        np.testing.assert_array_equal(res.signals[name]["value"].to_numpy(), truth[name])
        np.testing.assert_array_equal(res.signals[name]["t_ns"].to_numpy(), truth["t_ns"])
    assert res.sources["psi"] == SignalSource("/hitch/angle", "angle")
    assert "wheel_left" in res.missing
    assert res.problems == []
    assert infer_robot(log, res) == "tractor_trailer"


def test_ros2_defaults_yaw_from_quaternion(tmp_path, truth, mcap_writers):
    log = read_log(mcap_writers.ros2(tmp_path / "r.mcap", truth))
    res = resolve_signals(log)
    assert set(DRIVE) <= set(res.signals)
    np.testing.assert_allclose(res.signals["yaw"]["value"].to_numpy(), truth["yaw"], atol=1e-12)
    np.testing.assert_array_equal(res.signals["v"]["value"].to_numpy(), truth["v"])
    np.testing.assert_array_equal(res.signals["wheel_left"]["value"].to_numpy(), 10 * truth["x"])


def test_ros2_wheels_picked_by_name_not_index(tmp_path, truth, mcap_writers):
    log = read_log(mcap_writers.ros2(tmp_path / "r.mcap", truth, wheels_swapped=True))
    res = resolve_signals(log)
    assert log.topics["/wheels"]["name.0"][0] == "right_wheel_joint"
    np.testing.assert_array_equal(res.signals["wheel_left"]["value"].to_numpy(), 10 * truth["x"])
    np.testing.assert_array_equal(res.signals["wheel_right"]["value"].to_numpy(), 12 * truth["x"])
    assert res.sources["wheel_left"].field == "position[name~left]"


def _renamed_log(tmp_path, truth, mcap_writers):
    topics = {"/trailer/joint": {"deg": "psi_deg"}, "/cmd": {"k": "kappa_cmd"}}
    data = {**truth, "psi_deg": np.degrees(truth["psi"])}
    return read_log(mcap_writers.json(tmp_path / "other.mcap", data, topics=topics))


def test_channel_map_toml_maps_other_names(tmp_path, truth, mcap_writers):
    log = _renamed_log(tmp_path, truth, mcap_writers)
    assert resolve_signals(log).signals == {}
    toml = tmp_path / "map.toml"
    toml.write_text(
        '[signals.psi]\ntopic = "/trailer/joint"\nfield = "deg"\ntransform = "deg_to_rad"\n'
        '[signals.kappa_cmd]\ntopic = "/cmd"\nfield = "k"\n'
    )
    res = resolve_signals(log, load_channel_map(toml))
    np.testing.assert_allclose(res.signals["psi"]["value"].to_numpy(), truth["psi"], rtol=1e-12)
    np.testing.assert_array_equal(res.signals["kappa_cmd"]["value"].to_numpy(), truth["kappa_cmd"])
    assert res.sources["psi"] == SignalSource("/trailer/joint", "deg", "deg_to_rad")


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("not toml [", "not a readable TOML"),
        ("[other]\na = 1\n", "expected a [signals.NAME] table"),
        ('[signals.speed]\ntopic = "/a"\nfield = "b"\n', "not a logical signal"),
        ('[signals.psi]\ntopic = "/a"\n', "needs string keys topic and field"),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\ntransform = "x"\n', "transform 'x'"),
    ],
)
def test_bad_channel_map_files(tmp_path, text, needle):
    toml = tmp_path / "bad.toml"
    toml.write_text(text)
    with pytest.raises(ChannelMapError) as info:
        load_channel_map(toml)
    assert needle in str(info.value)
    assert str(toml) in str(info.value)


def test_missing_channel_map_file(tmp_path):
    with pytest.raises(ChannelMapError, match="no such channel-map file"):
        load_channel_map(tmp_path / "absent.toml")


def test_channel_map_naming_absent_topic_or_field(tmp_path, truth, mcap_writers):
    log = _renamed_log(tmp_path, truth, mcap_writers)
    with pytest.raises(ChannelMapError, match=r"topic '/nope'.*Topics in the log: /cmd"):
        resolve_signals(log, {"psi": SignalSource("/nope", "x")})
    with pytest.raises(ChannelMapError, match=r"field 'angle'.*Its fields: deg"):
        resolve_signals(log, {"psi": SignalSource("/trailer/joint", "angle")})


def test_csv_columns_by_logical_name(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("t,q1,q2,tau1,tau2,other\n0,0.1,0.2,1,2,9\n0.01,0.2,0.3,1.5,2.5,9\n")
    log = read_log(path)
    res = resolve_signals(log)
    assert sorted(res.signals) == ["q1", "q2", "tau1", "tau2"]
    assert res.signals["tau2"]["value"].to_list() == [2.0, 2.5]
    assert "q" not in res.missing
    assert "qd" in res.missing
    robot, reason = explain_robot(log, res)
    assert robot == "manipulator"
    assert "q1" in reason
    assert "tau2" in reason


def test_joint_states_arrays_become_per_joint_signals(tmp_path):
    path = tmp_path / "arm.mcap"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        ch = w.register_channel("/joint_states", "json", w.register_schema("js", "jsonschema", b""))
        for i in range(5):
            msg = {"position": [0.1 * i, -0.1 * i], "velocity": [0.1, -0.1], "effort": [i, 2 * i]}
            w.add_message(ch, 1000 * i, json.dumps(msg).encode(), 1000 * i)
        w.finish()
    log = read_log(path)
    res = resolve_signals(log)
    assert sorted(res.signals) == ["q1", "q2", "qd1", "qd2", "tau1", "tau2"]
    assert res.signals["tau2"]["value"].to_list() == [0.0, 2.0, 4.0, 6.0, 8.0]
    assert infer_robot(log, res) == "manipulator"


def test_diff_drive_inferred_from_wheels(tmp_path, truth, mcap_writers):
    data = {**truth, "wl": 10 * truth["x"], "wr": 12 * truth["x"]}
    topics = {"/wheels": {"left": "wl", "right": "wr"}, "/cmd/vel": {"v": "v", "omega": "omega"}}
    log = read_log(mcap_writers.json(tmp_path / "dd.mcap", data, topics=topics))
    res = resolve_signals(log)
    assert {"wheel_left", "wheel_right", "v_cmd", "omega_cmd"} <= set(res.signals)
    assert infer_robot(log, res) == "diff_drive"


def test_metadata_robot_wins_and_is_checked(tmp_path, truth, mcap_writers):
    log = read_log(mcap_writers.json(tmp_path / "m.mcap", truth, metadata={"robot": "diff_drive"}))
    assert infer_robot(log, resolve_signals(log)) == "diff_drive"
    bad = read_log(mcap_writers.json(tmp_path / "b.mcap", truth, metadata={"robot": "boat"}))
    with pytest.raises(LogcalInputError, match="names robot 'boat'"):
        infer_robot(bad, resolve_signals(bad))


def test_no_drive_signals_lists_topics(tmp_path, truth, mcap_writers):
    topics = {"/battery": {"voltage": "v"}}
    log = read_log(mcap_writers.json(tmp_path / "n.mcap", truth, topics=topics))
    res = resolve_signals(log)
    assert res.signals == {}
    with pytest.raises(NoDriveSignalsError, match=r"Topics in the log: /battery"):
        infer_robot(log, res)


def test_yaw_from_quaternion_is_exact_for_rotations_about_z():
    import polars as pl

    from logtools.channel_map import TRANSFORMS

    yaw = np.linspace(-math.pi + 1e-9, math.pi - 1e-9, 101)
    frame = pl.DataFrame({"q.x": 0.0, "q.y": 0.0, "q.z": np.sin(yaw / 2), "q.w": np.cos(yaw / 2)})
    got = frame.select(TRANSFORMS["yaw_from_quaternion"].value(frame, "q")).to_series().to_numpy()
    np.testing.assert_allclose(got, yaw, atol=1e-12)
