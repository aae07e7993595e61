"""A tiny random slice of bench/diff_drive_coverage.py: one seed drawn afresh each run. It
checks the study's machinery end to end and the precision target on that seed (met by all
seeds of the full study); coverage is a statistical claim shown by the study, not here."""

from __future__ import annotations

import numpy as np

from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import calibrate_lsq
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive


def test_a_random_slice_of_the_coverage_study() -> None:
    seed = int(np.random.default_rng().integers(0, 10_000))
    nominal = DiffDriveParams(0.042, 0.042, 0.20)
    true = DiffDriveParams(2 * 0.042 * 1.01 / 2.01, 2 * 0.042 / 2.01, 0.203)
    cfg = SimConfig(
        true, nominal, slip_std=0.005, counts_per_rev=2797, pose_noise=(0.001, 0.001, 0.002)
    )
    sim = simulate_diff_drive(
        mixed_commands(nominal, 180.0, np.random.default_rng(seed)), cfg, seed
    )
    run = DriveRun(sim.t, sim.wheel_right, sim.wheel_left, sim.x, sim.y, sim.yaw)
    res, _ = calibrate_lsq([run], n_boot=100, seed=seed)
    p = res.parameters
    assert abs(p["wheel_radius_right"].value / true.r_R - 1) < 1e-3, seed
    assert abs(p["wheel_radius_left"].value / true.r_L - 1) < 1e-3, seed
    assert abs(p["track_width"].value / true.b - 1) < 5e-3, seed
