"""The differential drive's results carry the N x N covariance of (r_R, r_L, b) their intervals
come from: the least squares' block bootstrap and UMBmark's delta method."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import PARAMETER_NAMES, calibrate_lsq
from calib.diff_drive.sim import (
    DiffDriveSim,
    SimConfig,
    mixed_commands,
    simulate_diff_drive,
    square_commands,
)
from calib.diff_drive.umbmark import umbmark, umbmark_result

NOM = DiffDriveParams(0.042, 0.042, 0.20)


def _run(s: DiffDriveSim) -> DriveRun:
    return DriveRun(s.t, s.wheel_right, s.wheel_left, s.x, s.y, s.yaw)


def test_lsq_result_carries_the_bootstrap_covariance() -> None:
    true = DiffDriveParams(0.042 * 1.005, 0.042 * 0.995, 0.203)
    sim = simulate_diff_drive(
        mixed_commands(NOM, 200.0, np.random.default_rng(3)), SimConfig(true, NOM), seed=3
    )
    result, fit = calibrate_lsq([_run(sim)], n_boot=40)
    assert result.parameter_names == PARAMETER_NAMES
    cov = np.array(result.covariance)
    np.testing.assert_allclose(cov, np.cov(fit.boot[:, :3].T), rtol=1e-12)
    std = np.array([result.parameters[n].std for n in PARAMETER_NAMES])
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), std, rtol=1e-12)
    corr = np.array(result.correlations)
    assert np.all(np.abs(corr) <= 1.0)
    assert np.allclose(corr, corr.T)


def _corrected(alpha: float, beta: float, side: float) -> np.ndarray:
    """UMBmark's corrections as its paper states them: b = b_nom (pi/2) / (pi/2 + alpha);
    beta = (L / b) 2 (Ed - 1) / (Ed + 1); r_R = 2 rbar Ed / (1 + Ed), r_L = 2 rbar / (1 + Ed)."""
    b = NOM.b * (np.pi / 2) / (np.pi / 2 + alpha)
    k = beta * b / (2 * side)
    ed = (1 + k) / (1 - k)
    rbar = 0.5 * (NOM.r_R + NOM.r_L)
    return np.array([2 * rbar * ed / (1 + ed), 2 * rbar / (1 + ed), b])


def test_umbmark_covariance_is_the_delta_method_of_its_corrections() -> None:
    true = DiffDriveParams(0.042 * 1.001, 0.042 * 0.999, 0.2 * 1.002)
    cfg = SimConfig(true, NOM, slip_std=0.01, pose_noise=(0.002, 0.002, 0.002))
    runs = [
        _run(simulate_diff_drive(square_commands(NOM, 1.7, d), cfg, seed=i))
        for i, d in enumerate((1, 1, 1, -1, -1, -1))
    ]
    res = umbmark(runs, NOM, side=1.7)
    x0 = _corrected(res.alpha, res.beta, res.side)
    np.testing.assert_allclose(x0, [res.params.r_R, res.params.r_L, res.params.b], rtol=1e-12)
    h = 1e-7
    jac = np.column_stack(
        [
            (
                _corrected(res.alpha + h, res.beta, res.side)
                - _corrected(res.alpha - h, res.beta, res.side)
            )
            / (2 * h),
            (
                _corrected(res.alpha, res.beta + h, res.side)
                - _corrected(res.alpha, res.beta - h, res.side)
            )
            / (2 * h),
        ]
    )
    want = jac @ res.cov_ab @ jac.T
    assert np.all(np.diag(want) > 0)
    np.testing.assert_allclose(res.params_cov, want, rtol=1e-5, atol=1e-20)
    result = umbmark_result(res, 3, 3)
    assert np.sqrt(np.array(result.covariance)[2, 2]) == pytest.approx(
        result.parameters["track_width"].std, rel=1e-9
    )
    assert result.derived["wheel_radius_ratio"].std == pytest.approx(res.Ed_std, rel=1e-12)
    # the radii move together in opposite directions (their mean stays nominal)
    assert result.correlations is not None
    assert result.correlations[0][1] == pytest.approx(-1.0)


def test_umbmark_does_not_claim_each_radius() -> None:
    """UMBmark's radii keep the nominal mean: each is not determined (no interval of the ratio's
    spread alone, "± 5e-07 m [0.04198, 0.04198]"); the ratio and the track width carry the
    interval propagated from the runs' end-point scatter (issue 33, item 10)."""
    true = DiffDriveParams(0.042 * 1.001, 0.042 * 0.999, 0.2 * 1.002)
    cfg = SimConfig(true, NOM, slip_std=0.01, pose_noise=(0.002, 0.002, 0.002))
    runs = [
        _run(simulate_diff_drive(square_commands(NOM, 1.7, d), cfg, seed=i))
        for i, d in enumerate((1, 1, 1, -1, -1, -1))
    ]
    res = umbmark(runs, NOM, side=1.7)
    result = umbmark_result(res, 3, 3)
    for name in ("wheel_radius_right", "wheel_radius_left"):
        e = result.parameters[name]
        assert not e.identifiable
        assert e.report().startswith(f"{name}: not determined by this log: UMBmark determines")
        assert math.isfinite(e.value)  # the corrected value stays for dead reckoning
    ratio = result.derived["wheel_radius_ratio"]
    assert ratio.value == pytest.approx(res.params.r_R / res.params.r_L, rel=1e-12)
    lo, hi = ratio.ci95
    assert lo < ratio.value < hi
    b = result.parameters["track_width"]
    assert b.identifiable
    assert b.ci95[0] < b.value < b.ci95[1]
    from calib.results import AnalysisResult
    from logtools.robots.diff_drive.report import _umbmark_lines

    (line,) = _umbmark_lines(AnalysisResult("diff_drive", [], [result], None))
    assert line.startswith("UMBmark: wheel_radius_ratio = ")
    assert "; not determined: wheel_radius_right, wheel_radius_left (UMBmark keeps" in line
    assert "  [" not in line  # a unitless ratio: no empty unit
