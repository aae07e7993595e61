"""The paper's tracking law (Eqs. 40-44) against the control-point law, the motor limit and the
gain criterion of ``reproduce wmr``; discovery's speed-proportional slip and its family-wise
level. Deterministic: fixed seeds, facts that follow from the models."""

from __future__ import annotations

import numpy as np
import pytest

from calib.diff_drive.data import DriveRun
from calib.diff_drive.discovery import FAMILY_ALPHA, discover
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import calibrate_lsq
from calib.diff_drive.planner import plan_path
from calib.diff_drive.reproduce import W_MAX_RAD_S, design_kp
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive
from calib.diff_drive.tracker import TrackerGains, track

NOM = DiffDriveParams(0.05, 0.05, 0.30)
GAINS = TrackerGains(kp=1.5, kd=0.0, l_c=0.1, w_max=100.0)
OFF = float(np.deg2rad(20.0))


def _lateral_end(law: str) -> float:
    line = plan_path((0.0, 0.0, 0.0), (4.0, 0.0), v=0.2, dt=0.01)
    run = track(line, (0.0, 0.0, OFF), NOM, NOM, GAINS, 0, law=law)  # type: ignore[arg-type]
    return abs(float(run.y[-1]))


def test_paper_law_leaves_the_lateral_offset_the_control_point_law_removes() -> None:
    assert _lateral_end("paper") > 0.01  # no lateral feedback in Eqs. 41-44
    assert _lateral_end("control_point") < 0.002


def test_paper_law_follows_a_drivable_path_exactly_without_model_error() -> None:
    ref = plan_path((0.0, 0.0, OFF), (4.0, 0.0), v=0.2, sigma=0.6, dt=0.01)
    run = track(ref, (0.0, 0.0, OFF), NOM, NOM, GAINS, 0, law="paper")
    assert np.max(np.hypot(run.x - ref.x, run.y - ref.y)) < 2e-3
    assert abs(run.y[-1]) < 2e-3


def test_motor_limit_holds_and_design_gain_sits_at_it() -> None:
    kp = design_kp(NOM, 0.2, OFF, W_MAX_RAD_S)
    # at cruise, the 20 deg heading error at the design gain asks exactly w_max of a wheel
    assert (0.2 + kp * OFF * NOM.half_track) / NOM.r_R == pytest.approx(W_MAX_RAD_S)
    gains = TrackerGains(kp=4 * kp, kd=0.0, w_max=W_MAX_RAD_S)
    line = plan_path((0.0, 0.0, 0.0), (4.0, 0.0), v=0.2, dt=0.01)
    run = track(line, (0.0, 0.0, OFF), NOM, NOM, gains, 0, law="paper")
    peak = np.max(np.abs(np.concatenate([run.w_right, run.w_left])))
    assert peak == pytest.approx(W_MAX_RAD_S)


def test_unknown_law_is_refused() -> None:
    line = plan_path((0.0, 0.0, 0.0), (1.0, 0.0), v=0.2, dt=0.01)
    with pytest.raises(ValueError, match="unknown tracking law"):
        track(line, (0.0, 0.0, 0.0), NOM, NOM, GAINS, law="pure_pursuit")  # type: ignore[arg-type]


def _discovery(slip: float, seed: int) -> list[str]:
    nominal = DiffDriveParams(0.042, 0.042, 0.20)
    cfg = SimConfig(
        nominal,
        nominal,
        slip_std=0.005,
        slip_per_speed=slip,
        counts_per_rev=2797,
        pose_noise=(0.001, 0.001, 0.002),
    )
    sim = simulate_diff_drive(
        mixed_commands(nominal, 180.0, np.random.default_rng(seed)), cfg, seed
    )
    run = DriveRun(sim.t, sim.wheel_right, sim.wheel_left, sim.x, sim.y, sim.yaw)
    _, fit = calibrate_lsq([run], n_boot=100, seed=seed)
    d = discover([run], fit, nominal)
    assert f"each at the {1 - FAMILY_ALPHA / 3:.1%} level" in d.notes[0]
    return d.named


def test_discovery_names_speed_proportional_slip() -> None:
    assert "wheel_slip" in _discovery(0.05, seed=7)


def test_discovery_quiet_on_a_clean_log() -> None:
    assert _discovery(0.0, seed=7) == []
