"""The OptiOdom reader on a real recording, read_log dispatch, session folders, the plugin's
analysis and identification of a TurtleBot /joint_states log."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive
from logtools.errors import LogcalInputError
from logtools.readers import read_log
from logtools.readers.optiodom import read_optiodom, session_runs
from logtools.runs import expand_runs


def test_reader_real_run(square_run: Path) -> None:
    log = read_log(square_run)  # dispatch: headerless CSV with a type=diff metadata beside it
    frame = log.topics["csv"]
    raw = np.loadtxt(square_run, delimiter=",")
    k = 2 * math.pi / (43.7 * 64)
    np.testing.assert_allclose(frame["wheel_right"].to_numpy(), np.cumsum(raw[:, 4]) * k)
    np.testing.assert_allclose(frame["wheel_left"].to_numpy(), np.cumsum(raw[:, 5]) * k)
    np.testing.assert_allclose(frame["yaw"].to_numpy(), raw[:, 3])
    assert frame["t_ns"][1] == 50_000_000
    nominal = log.metadata["logcal.nominal"]
    assert float(nominal["wheel_radius_right"]) == pytest.approx(0.042)
    assert float(nominal["track_width"]) == pytest.approx(0.2)
    assert float(nominal["square_side"]) == pytest.approx(1.7)
    assert log.metadata["logcal"] == {"robot": "diff_drive"}


def test_session_folder_expands_to_runs(square_run: Path) -> None:
    runs = expand_runs([square_run.parent])
    assert runs == session_runs(square_run.parent)
    assert len(runs) == 6
    assert all("_run-" in p.name for p in runs)


def test_reader_errors_name_the_file(tmp_path: Path, square_run: Path) -> None:
    with pytest.raises(LogcalInputError, match="metadata"):
        read_optiodom(tmp_path / "x_run-01.csv")
    shutil.copy(square_run.with_name("231220200029_metadata.csv"), tmp_path / "s_metadata.csv")
    bad = tmp_path / "s_run-01.csv"
    bad.write_text("0,1,2\n0.05,1,2\n")
    with pytest.raises(LogcalInputError, match=r"s_run-01\.csv"):
        read_log(bad)


def test_plugin_analyzes_a_real_session(square_run: Path) -> None:
    from logtools.analyze import analyze_log

    _, res = analyze_log(square_run)
    d = res.to_dict()
    assert d["robot"] == "diff_drive"
    for name in ("wheel_radius_right", "wheel_radius_left", "track_width"):
        est = d["estimate"][name]
        assert est["unit"] == "m"
        assert est["ci95"][0] < est["value"] < est["ci95"][1]
    row = d["dead_reckoning"]["runs"][0]
    assert row["nominal"]["end_point_error_m"] > 0
    assert row["calibrated"]["end_point_error_m"] > 0


def test_turtlebot_joint_states_is_a_diff_drive(tmp_path: Path) -> None:
    from logtools.load import load_log
    from logtools.writers.diff_drive import write_run

    nom = DiffDriveParams(0.033, 0.033, 0.16)
    sim = simulate_diff_drive(
        mixed_commands(nom, 20.0, np.random.default_rng(0)), SimConfig(nom, nom), seed=0
    )
    path = tmp_path / "turtle.mcap"
    write_run(path, sim, encoding="ros2", style="turtlebot", metadata={})  # no robot record
    loaded = load_log(path)
    assert loaded.robot == "diff_drive"
    np.testing.assert_allclose(loaded.frame["wheel_left"].to_numpy()[-1], sim.wheel_left[-1])
    np.testing.assert_allclose(loaded.frame["wheel_right"].to_numpy()[-1], sim.wheel_right[-1])


def test_views_write_an_rrd(square_run: Path, tmp_path: Path) -> None:
    from logtools.analyze import analyze_log
    from viz.diff_drive.views import log_views

    loaded, res = analyze_log(square_run)
    out = log_views(tmp_path / "dd.rrd", loaded, res)
    assert out.stat().st_size > 1000
