"""Arm logs: writer round trip through the readers, the real DFKI log, CLI exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import logtools.robots as robots
from logtools.analyze import AnalysisConfig
from logtools.cli.main import main
from logtools.load import load_log
from logtools.robots.manipulator import PLUGIN
from logtools.robots.manipulator.options import ManipulatorOptions

DFKI = Path(__file__).resolve().parents[3] / "shared/realworld_arm/dfki_double_pendulum"


@pytest.fixture(autouse=True)
def _plugin() -> None:
    robots.register(PLUGIN)


@pytest.mark.parametrize("suffix", ["json.mcap", "ros2.mcap", "csv"])
def test_simulated_log_round_trip(tmp_path: Path, suffix: str) -> None:
    enc = suffix.split(".")[0]
    out = tmp_path / f"arm.{suffix}"
    args = ["simulate", "manipulator", "--out", str(out), "--duration", "6", "--seed", "2"]
    assert main([*args, "--encoding", enc]) == 0
    loaded = load_log(out)
    assert [c for c in loaded.frame.columns if c.startswith("tau")] == ["tau1", "tau2"]
    if enc == "csv":  # no metadata: the model must be given
        from logtools.errors import LogcalInputError

        with pytest.raises(LogcalInputError, match="--urdf"):
            PLUGIN.analyze(loaded, AnalysisConfig(), lambda _m: None)
        return
    res = PLUGIN.analyze(loaded, AnalysisConfig(), lambda _m: None)
    doc = json.loads(json.dumps(res.to_dict()))
    assert doc["robot"] == "manipulator"
    assert doc["joints"] == ["joint1", "joint2"]
    assert doc["excitation"]["condition_number"] > 1
    assert set(doc["torque_rms_holdout"]) == {"joint1", "joint2"}
    truth = doc["truth_base"]
    for name, est in doc["estimate"].items():
        if name in truth:
            lo, hi = est["ci95"]
            assert lo - 0.05 * abs(truth[name]) <= truth[name] <= hi + 0.05 * abs(truth[name])


@pytest.mark.skipif(not DFKI.is_dir(), reason="shared real recordings not present")
def test_dfki_real_log() -> None:
    loaded = load_log(DFKI / "dp_C0_20220914_trajectory_00.mcap")
    assert loaded.robot == "manipulator"
    cfg = AnalysisConfig(
        robot_options={
            "manipulator": ManipulatorOptions(urdf=str(DFKI / "design_C.0_model_3.1_acrobot.urdf"))
        }
    )
    res = PLUGIN.analyze(loaded, cfg, lambda _m: None)
    s = res.sections
    assert s["joints"] == ["Joint1", "Joint2"]
    assert 0 < s["torque_rms_holdout_ratio"] < 1
    assert all(np.isfinite(v) for v in s["torque_rms_holdout"].values())
    assert any("world" in n for n in s["model"]["notes"])


def test_cli_exit_codes(tmp_path: Path, capsys) -> None:
    assert (
        main(["simulate", "manipulator", "--out", str(tmp_path / "a.mcap"), "--arm", "nosuch"]) == 2
    )
    assert (
        main(["simulate", "manipulator", "--out", str(tmp_path / "a.mcap"), "--duration", "0"]) == 2
    )
    assert main(["reproduce", "momentum", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["omega_rank"] == 9


def test_cutoff_option_and_conceal_choice(tmp_path: Path, capsys) -> None:
    log = tmp_path / "arm.mcap"
    assert main(["simulate", "manipulator", "--out", str(log), "--duration", "6"]) == 0
    assert main(["simulate", "manipulator", "--out", str(log), "--conceal", "mass"]) == 2
    capsys.readouterr()
    assert main(["analyze", str(log), "--cutoff-hz", "5", "--no-discovery", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["model"]["cutoff_hz"] == 5.0
    assert main(["analyze", str(log), "--cutoff-hz", "-1", "--json"]) == 2


def test_holdout_is_at_the_logged_stamps() -> None:
    from calib.manipulator.identify import identify_arm
    from calib.manipulator.planar import PAPER_ARM, Planar2Link
    from calib.manipulator.simulate import Friction, Sensors, simulate_planar

    run = simulate_planar(PAPER_ARM, Friction(), duration_s=8.0, sensors=Sensors(jitter_s=4e-4))
    res = identify_arm(Planar2Link(PAPER_ARM), run.t_s, run.q, run.tau)
    h = res.holdout
    assert res.sig.raw_t_s is not None
    # every held-out time is a logged stamp, the torque compared is the logged one (not resampled)
    assert np.all(np.isin(h.t_s, res.sig.raw_t_s))
    assert not np.all(np.isin(h.t_s, res.sig.t_s))
    assert np.all(np.isin(h.measured[:, 0], run.tau[:, 0]))
    assert len(h.t_s) == len(h.measured) == len(h.predicted) > 0.35 * len(run.t_s)
