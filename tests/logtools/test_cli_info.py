"""`logcal info`: in-process through main(argv), and once end to end as a subprocess."""

from __future__ import annotations

import json
import subprocess
import sys

from logtools.cli.main import main


def test_info_text(tmp_path, truth, mcap_writers, capsys):
    path = mcap_writers.json(tmp_path / "d.mcap", truth, metadata={"robot": "tractor_trailer"})
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "robot: tractor_trailer (metadata record 'logcal')" in out
    assert "  /hitch/angle  hitch/angle  [json/jsonschema]  200 msgs  50.0 Hz" in out
    assert "psi         <- /hitch/angle : angle  200 samples" in out
    assert "time span: 3.980 s" in out
    assert (
        "signals missing: v_cmd, omega_cmd, steer, steer_cmd, x2, y2, yaw2, wheel_right, "
        "wheel_left, odom_v, odom_omega, gyro_z, gps_lat, gps_lon, q, qd, tau" in out
    )
    assert "problems" not in out


def test_info_json_infers_robot_and_reports_sources(tmp_path, truth, mcap_writers, capsys):
    path = mcap_writers.ros2(tmp_path / "r.mcap", truth, wheels_swapped=True)
    assert main(["info", "--json", str(path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "tractor_trailer"
    assert doc["robot_reason"] == "signal psi"
    assert doc["signals"]["yaw"]["transform"] == "yaw_from_quaternion"
    assert doc["signals"]["wheel_left"]["field"] == "position[name~left]"
    assert doc["signals"]["psi"]["samples"] == 200
    odom = next(t for t in doc["topics"] if t["topic"] == "/odom")
    assert odom["schema_name"] == "nav_msgs/msg/Odometry"
    assert odom["message_count"] == 200
    assert abs(odom["rate_hz"] - 50.0) < 1e-9
    assert abs(doc["duration_s"] - 3.98) < 1e-9


def test_info_with_channel_map(tmp_path, truth, mcap_writers, capsys):
    path = mcap_writers.json(tmp_path / "o.mcap", truth, topics={"/joint": {"a": "psi"}})
    toml = tmp_path / "map.toml"
    toml.write_text('[signals.psi]\ntopic = "/joint"\nfield = "a"\n')
    assert main(["info", "--json", "--channel-map", str(toml), str(path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["signals"]["psi"]["topic"] == "/joint"
    assert doc["robot"] == "tractor_trailer"


def test_info_prints_problems_of_a_truncated_log(tmp_path, truth, mcap_writers, capsys):
    full = mcap_writers.json(tmp_path / "f.mcap", truth, chunk_size=2048).read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full[: len(full) // 2])
    assert main(["info", str(cut)]) == 0
    out = capsys.readouterr().out
    assert "problems (1):" in out
    assert "bytes after the last good record" in out


def test_info_end_to_end_subprocess(tmp_path, truth, mcap_writers):
    path = mcap_writers.json(tmp_path / "e.mcap", truth)
    code = "from logtools.cli.main import run; run()"
    ok = subprocess.run(
        [sys.executable, "-c", code, "info", "--json", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    assert json.loads(ok.stdout)["signals"]["psi"]["samples"] == 200
    bad = subprocess.run(
        [sys.executable, "-c", code, "info", str(tmp_path / "absent.mcap")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2
    assert bad.stderr.startswith("logcal: error: ")
    assert "Traceback" not in bad.stderr
