"""End to end on the user's tractor-trailer bag: the empty Odometry twist is detected and
not used, the steering command becomes kappa_cmd with the wheelbase, the trailer pose maps to
x2/y2/yaw2, header stamps and /tf frames are read, and the recorder stall is one gap."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from bagmaker import T0_NS, WHEELBASE, Drive, write_foxy_db3, write_rosbag2

from logtools.channel_map import ChannelMap, load_channel_map, resolve_signals
from logtools.cli.main import main
from logtools.errors import ChannelMapEntryError
from logtools.load import load_log
from logtools.problems import ProblemKind
from logtools.readers import read_log
from logtools.robots.tractor_trailer.curvature import KappaCmdKind

# The README's worked example (kept in step with it).
TRUCK_MAP = """
[robot]
type = "tractor_trailer"
wheelbase = 0.42

[signals.v_cmd]
topic = "/cmd_vel"
field = "linear.x"

[signals.steer_cmd]
topic = "/cmd_vel"
field = "angular.z"
unit = "rad"

[signals.omega_cmd]
off = true

[signals.psi]
topic = "/encoder/angle"
field = "data"

[signals.steer]
topic = "/kelo_angle"
field = "data"

[signals.x]
topic = "/truck_trailer/truck_pose"
field = "pose.position.x"
stamp = "header"

[signals.y]
topic = "/truck_trailer/truck_pose"
field = "pose.position.y"
stamp = "header"

[signals.yaw]
topic = "/truck_trailer/truck_pose"
field = "pose.orientation"
transform = "yaw_from_quaternion"
stamp = "header"

[signals.x2]
topic = "/odom"
field = "pose.pose.position.x"

[signals.y2]
topic = "/odom"
field = "pose.pose.position.y"

[signals.yaw2]
topic = "/odom"
field = "pose.pose.orientation"
transform = "yaw_from_quaternion"
"""


def _map(tmp_path: Path, text: str = TRUCK_MAP, name: str = "truck.toml") -> ChannelMap:
    path = tmp_path / name
    path.write_text(text)
    return load_channel_map(path)


@pytest.fixture(scope="module")
def foxy(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Drive]:
    drive = Drive(duration_s=30.0)
    return write_foxy_db3(tmp_path_factory.mktemp("bags") / "foxy", drive), drive


def test_zero_twist_is_reported_and_kappa_comes_from_the_path(foxy, tmp_path):
    path, drive = foxy
    loaded = load_log(path, _map(tmp_path))
    flat = {f.name: f for f in loaded.signals.flat}
    assert set(flat) == {"v", "omega"}
    assert (flat["v"].topic, flat["v"].field, flat["v"].value) == (
        "/odom",
        "twist.twist.linear.x",
        0,
    )
    assert "v" not in loaded.signals.signals
    assert "omega" not in loaded.frame.columns
    said = [str(p) for p in loaded.problems if "carries nothing" in str(p)]
    assert len(said) == 2
    assert any("'/odom'" in p and "'twist.twist.angular.z'" in p for p in said)
    src = loaded.frame["kappa_source"].drop_nulls()
    assert set(src.unique().to_list()) <= {"path", "steer"}
    assert (src == "path").mean() > 0.9
    # the path curvature of the tractor is tan(steer) / wheelbase (away from the gap's edges)
    frame = loaded.frame.filter(loaded.frame["kappa_source"] == "path")
    t_s = (frame["t_ns"].to_numpy() - T0_NS) * 1e-9
    away = (np.abs(t_s - 13.0) > 3.5) & (t_s > 2) & (t_s < drive.duration_s - 2)
    truth = np.tan(drive.steer(t_s)) / WHEELBASE
    err = frame["kappa"].to_numpy() - truth
    assert np.median(np.abs(err[away])) < 0.02


def test_steering_command_gives_kappa_cmd_with_the_wheelbase(foxy, tmp_path):
    path, _drive = foxy
    loaded = load_log(path, _map(tmp_path))
    origin = loaded.signals.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.kind is KappaCmdKind.STEERING
    assert origin.source == "tan(steer_cmd) / 0.42"
    assert "wheelbase 0.42 m from the channel map" in origin.description
    assert "truck.toml [robot] wheelbase" in origin.description
    raw = loaded.signals.signals["kappa_cmd"]
    cmd = loaded.log.topics["/cmd_vel"]
    np.testing.assert_array_equal(raw["t_ns"].to_numpy(), cmd["t_ns"].to_numpy())
    np.testing.assert_allclose(raw["value"].to_numpy(), np.tan(cmd["angular.z"]) / 0.42, rtol=1e-14)
    assert loaded.signals.sources["kappa_cmd"].topic == "(derived)"
    assert loaded.robot == "tractor_trailer"
    assert {"x2", "y2", "yaw2", "steer", "steer_cmd", "psi", "kappa_cmd"} <= set(
        loaded.frame.columns
    )
    assert "omega_cmd" not in loaded.signals.signals  # switched off


def test_wheelbase_from_the_metadata_record_or_not_derived(tmp_path):
    drive = Drive(duration_s=8.0, stall=None)
    no_wheelbase = TRUCK_MAP.replace("wheelbase = 0.42\n", "")
    bag = write_rosbag2(tmp_path / "meta", drive, custom={"logcal.wheelbase": "0.5"})
    res = resolve_signals(read_log(bag), _map(tmp_path, no_wheelbase))
    origin = res.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.source == "tan(steer_cmd) / 0.5"
    assert "wheelbase 0.5 m from the logcal metadata record" in origin.description
    bare = write_rosbag2(tmp_path / "bare", drive)
    res = resolve_signals(read_log(bare), _map(tmp_path, no_wheelbase))
    assert "kappa_cmd" not in res.signals
    assert "kappa_cmd" not in res.origins
    assert any("no wheelbase is known" in p and "not derived" in p for p in res.problems)


def test_saturated_steering_is_reported_and_left_out(tmp_path):
    drive = Drive(duration_s=20.0, stall=None, steer_amp=1.56)  # up to 89.4 deg
    res = resolve_signals(read_log(write_foxy_db3(tmp_path / "sat", drive)), _map(tmp_path))
    steer = res.signals["steer_cmd"]["value"].to_numpy()
    kappa = res.signals["kappa_cmd"]["value"].to_numpy()
    saturated = np.abs(steer) >= math.radians(85)
    assert saturated.any()
    assert kappa.size == np.count_nonzero(~saturated)
    assert np.all(np.isfinite(kappa))
    assert np.max(np.abs(kappa)) < math.tan(math.radians(85)) / 0.42
    note = next(p for p in res.problems if "steer_cmd" in p and "are saturated" in p)
    assert f"{saturated.sum()} of {steer.size} samples of steer_cmd" in note
    assert any("samples of steer (/kelo_angle:data)" in p for p in res.problems)


def test_without_a_map_the_twist_command_gives_kappa_cmd_with_a_warning(foxy):
    path, _ = foxy
    res = resolve_signals(read_log(path))
    origin = res.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.kind is KappaCmdKind.TWIST
    assert origin.by_robot
    assert any("map it as steer_cmd" in p for p in res.problems)
    assert res.sources["x"].topic == "/odom"  # ROS default: the Odometry pose
    assert {f.name for f in res.flat} == {"v", "omega"}


def test_one_gap_for_a_stall_on_every_topic(foxy, tmp_path, capsys):
    path, drive = foxy
    loaded = load_log(path, _map(tmp_path))
    assert len(loaded.gaps) == 1
    gap = loaded.gaps[0]
    assert set(gap.signals) == set(loaded.signals.signals)
    t0, t1 = (gap.t0_ns - T0_NS) * 1e-9, (gap.t1_ns - T0_NS) * 1e-9
    assert drive.stall is not None
    assert drive.stall[0] - 0.05 < t0 <= drive.stall[0]
    assert drive.stall[1] <= t1 < drive.stall[1] + 0.05
    stall_notes = [p for p in loaded.problems if p.kind is ProblemKind.GAP]
    assert len(stall_notes) == 1
    assert (stall_notes[0].t0_ns, stall_notes[0].t1_ns) == (gap.t0_ns, gap.t1_ns)
    assert stall_notes[0].count == len(loaded.signals.signals)  # every signal: a recorder stall
    assert "recorder stall" in str(stall_notes[0])
    assert not any(p.kind is ProblemKind.DROPOUT and p.topic == "psi" for p in loaded.problems)
    toml = tmp_path / "truck.toml"
    assert main(["info", "--channel-map", str(toml), str(path)]) == 0
    out = capsys.readouterr().out
    assert "gaps (1):" in out
    assert "(2.33 s)  all signals" in out
    assert "kappa_cmd: tan(steer_cmd) / wheelbase" in out


def test_header_stamps_replace_the_record_time(tmp_path):
    drive = Drive(duration_s=6.0, stall=None, header_offset_s=0.25)
    res = resolve_signals(read_log(write_foxy_db3(tmp_path / "h", drive)), _map(tmp_path))
    x = res.signals["x"]["t_ns"].to_numpy()  # stamp = "header"
    record = read_log(tmp_path / "h").topics["/truck_trailer/truck_pose"]["t_ns"].to_numpy()
    assert np.max(np.abs(x - (record - 250_000_000))) <= 1
    x2 = res.signals["x2"]["t_ns"].to_numpy()  # stamp = "log"
    np.testing.assert_array_equal(x2, read_log(tmp_path / "h").topics["/odom"]["t_ns"].to_numpy())


def test_tf_child_frame_gives_the_pose(foxy, tmp_path):
    path, drive = foxy
    log = read_log(path)
    by_tf = resolve_signals(log, _map(tmp_path, '[tf]\nchild_frame = "truck_link"\n', "tf.toml"))
    assert by_tf.sources["x"].frame == "truck_link"
    x, y, yaw = drive.pose(drive.times["/tf"])  # every /tf message has truck_link, half a lidar
    np.testing.assert_allclose(by_tf.signals["x"]["value"].to_numpy(), x, atol=1e-12)
    np.testing.assert_allclose(by_tf.signals["y"]["value"].to_numpy(), y, atol=1e-12)
    np.testing.assert_allclose(by_tf.signals["yaw"]["value"].to_numpy(), yaw, atol=1e-12)
    per_signal = TRUCK_MAP.replace(
        '[signals.x]\ntopic = "/truck_trailer/truck_pose"\nfield = "pose.position.x"\n',
        '[signals.x]\ntopic = "/tf"\nfield = "transform.translation.x"\nframe = "truck_link"\n',
    )
    res = resolve_signals(log, _map(tmp_path, per_signal, "tf2.toml"))
    np.testing.assert_allclose(res.signals["x"]["value"].to_numpy(), x, atol=1e-12)
    tf_stamps = log.topics["/tf"]["transforms.0.header.stamp.sec"].to_numpy()
    assert res.signals["x"].height == tf_stamps.size  # stamp = "header" from the right element
    missing = per_signal.replace('frame = "truck_link"', 'frame = "nowhere"')
    with pytest.raises(ChannelMapEntryError, match=r"tf3.toml: \[signals.x.frame\].*'nowhere'"):
        resolve_signals(log, _map(tmp_path, missing, "tf3.toml"))


def test_the_readme_example_map_reads_the_bag(foxy, tmp_path):
    """The worked ROS example in README.md loads and maps the same signals as TRUCK_MAP."""
    readme = (Path(__file__).parents[2] / "README.md").read_text(encoding="utf-8")
    block = readme.split("# truck.toml", 1)[1].split("```", 1)[0]
    readme_map = _map(tmp_path, "#" + block, "readme.toml")
    assert dict(readme_map) == dict(_map(tmp_path))
    assert readme_map.off == frozenset({"omega_cmd"})
    path, _ = foxy
    res = resolve_signals(read_log(path), readme_map)
    origin = res.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.kind is KappaCmdKind.STEERING
    assert {f.name for f in res.flat} == {"v", "omega"}
