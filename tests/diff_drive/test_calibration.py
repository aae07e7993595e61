"""Calibration recovers exact parameters from noise-free simulation; UMBmark and the effective
track behave as their theory says."""

from __future__ import annotations

import numpy as np
import pytest

from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import calibrate_lsq, fit_lsq
from calib.diff_drive.sim import (
    DiffDriveSim,
    SimConfig,
    mixed_commands,
    simulate_diff_drive,
    square_commands,
)
from calib.diff_drive.skid import effective_track
from calib.diff_drive.umbmark import umbmark
from calib.errors import InsufficientDataError

NOM = DiffDriveParams(0.042, 0.042, 0.20)
TRUE = DiffDriveParams(0.042 * 1.005, 0.042 * 0.995, 0.203)


def _run(s: DiffDriveSim) -> DriveRun:
    return DriveRun(s.t, s.wheel_right, s.wheel_left, s.x, s.y, s.yaw)


def test_lsq_recovers_exact_parameters_noise_free() -> None:
    sim = simulate_diff_drive(
        mixed_commands(NOM, 200.0, np.random.default_rng(1)), SimConfig(TRUE, NOM), seed=1
    )
    result, fit = calibrate_lsq([_run(sim)], n_boot=30)
    got = result.parameters
    assert got["wheel_radius_right"].value == pytest.approx(TRUE.r_R, rel=1e-9)
    assert got["wheel_radius_left"].value == pytest.approx(TRUE.r_L, rel=1e-9)
    assert got["track_width"].value == pytest.approx(TRUE.b, rel=1e-9)
    assert fit.offset is not None
    assert abs(fit.offset) < 1e-9


def test_lsq_finds_a_ground_truth_marker_offset() -> None:
    sim = simulate_diff_drive(
        mixed_commands(NOM, 200.0, np.random.default_rng(2)), SimConfig(TRUE, NOM), seed=2
    )
    lx, ly = 0.03, -0.01  # marker 3 cm ahead, 1 cm right of the axle centre
    c, s = np.cos(sim.yaw), np.sin(sim.yaw)
    run = DriveRun(
        sim.t,
        sim.wheel_right,
        sim.wheel_left,
        sim.x + c * lx - s * ly,
        sim.y + s * lx + c * ly,
        sim.yaw,
    )
    fit = fit_lsq([run], n_boot=0)
    assert fit.offset == pytest.approx(complex(lx, ly), abs=1e-9)
    assert fit.params.b == pytest.approx(TRUE.b, rel=1e-9)


def test_lsq_refuses_a_log_without_motion() -> None:
    t = np.arange(0, 10, 0.05)
    z = np.zeros_like(t)
    with pytest.raises(InsufficientDataError):
        fit_lsq([DriveRun(t, z, z, z, z, z)])


def test_umbmark_recovers_small_systematic_errors_to_first_order() -> None:
    true = DiffDriveParams(0.042 * 1.001, 0.042 * 0.999, 0.2 * 1.002)
    cfg = SimConfig(true, NOM)
    runs = [
        _run(simulate_diff_drive(square_commands(NOM, 1.7, d), cfg, seed=i))
        for i, d in enumerate((1, 1, -1, -1))
    ]
    res = umbmark(runs, NOM, side=1.7)
    # first-order theory: the residual is second order in the errors (well below 10 % of them)
    assert res.Ed - 1 == pytest.approx(true.r_R / true.r_L - 1, rel=0.1)
    assert res.Eb - 1 == pytest.approx(true.b / NOM.b - 1, rel=0.1)


def test_umbmark_needs_both_directions() -> None:
    cfg = SimConfig(TRUE, NOM)
    runs = [_run(simulate_diff_drive(square_commands(NOM, 1.0, 1), cfg, seed=i)) for i in (0, 1)]
    with pytest.raises(InsufficientDataError, match="clockwise"):
        umbmark(runs, NOM)


def test_effective_track_of_a_skid_steer_from_gyro() -> None:
    cfg = SimConfig(NOM, NOM, track_factor=1.3)
    sim = simulate_diff_drive(mixed_commands(NOM, 120.0, np.random.default_rng(7)), cfg, seed=7)
    # the gyro rate of the simulator is the interval's mean rate: exact for the integral
    rate = np.concatenate([np.diff(sim.yaw_true) / np.diff(sim.t), [0.0]])
    est = effective_track(
        sim.t, sim.wheel_right, sim.wheel_left, NOM.r_R, NOM.r_L, yaw=sim.yaw_true, n_boot=20
    ).estimate
    assert est.value == pytest.approx(1.3 * NOM.b, rel=1e-9)
    gyro = effective_track(
        sim.t, sim.wheel_right, sim.wheel_left, NOM.r_R, NOM.r_L, yaw_rate=rate, n_boot=20
    ).estimate
    assert gyro.value == pytest.approx(1.3 * NOM.b, rel=0.01)
