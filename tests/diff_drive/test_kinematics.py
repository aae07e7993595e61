"""Kinematics and dead reckoning: exact round trips and exact integration of simulated wheels."""

from __future__ import annotations

import numpy as np
import pytest

from calib.diff_drive.dead_reckoning import dead_reckon
from calib.diff_drive.kinematics import (
    DiffDriveParams,
    control_point_inverse,
    control_point_velocity,
    forward,
    inverse,
)
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive

P = DiffDriveParams(0.0421, 0.0418, 0.203)


def test_forward_inverse_round_trip() -> None:
    rng = np.random.default_rng(3)
    v, om = rng.uniform(-1, 1, 50), rng.uniform(-3, 3, 50)
    wr, wl = inverse(P, v, om)
    v2, om2 = forward(P, wr, wl)
    np.testing.assert_allclose(v2, v, atol=1e-12)
    np.testing.assert_allclose(om2, om, atol=1e-12)


def test_spin_on_the_spot_and_straight() -> None:
    v, om = forward(DiffDriveParams(0.05, 0.05, 0.3), [1.0, 2.0], [-1.0, 2.0])
    assert v[0] == pytest.approx(0.0)
    assert om[0] == pytest.approx(2 * 0.05 / 0.3)
    assert v[1] == pytest.approx(0.1)
    assert om[1] == pytest.approx(0.0)


def test_control_point_round_trip_and_singular_axle() -> None:
    rng = np.random.default_rng(4)
    v, om, yaw = rng.uniform(-1, 1, 20), rng.uniform(-2, 2, 20), rng.uniform(-3, 3, 20)
    ux, uy = control_point_velocity(v, om, yaw, 0.12)
    v2, om2 = control_point_inverse(ux, uy, yaw, 0.12)
    np.testing.assert_allclose(v2, v, atol=1e-12)
    np.testing.assert_allclose(om2, om, atol=1e-12)
    with pytest.raises(ValueError, match="l_c"):
        control_point_inverse(1.0, 0.0, 0.0, 0.0)


def test_dead_reckoning_reproduces_exact_simulated_motion() -> None:
    cmds = mixed_commands(P, 60.0, np.random.default_rng(5))
    sim = simulate_diff_drive(cmds, SimConfig(true=P, nominal=P), seed=5)
    dr = dead_reckon(sim.t, sim.wheel_right, sim.wheel_left, P)
    np.testing.assert_allclose(dr.x, sim.x_true, atol=1e-9)
    np.testing.assert_allclose(dr.y, sim.y_true, atol=1e-9)
    np.testing.assert_allclose(dr.yaw, sim.yaw_true, atol=1e-12)
    paper = dead_reckon(sim.t, sim.wheel_right, sim.wheel_left, P, scheme="paper")
    np.testing.assert_allclose(paper.yaw, sim.yaw_true, atol=1e-12)  # Eq. 38 is exact
    # Eq. 39 (trapezoid, previous heading) is first order: close, not exact
    err = np.hypot(paper.x - sim.x_true, paper.y - sim.y_true)
    assert 1e-6 < err.max() < 0.05 * sim.x_true.size * 0.4 / 20


def test_dead_reckoning_straight_line_paper_scheme() -> None:
    t = np.arange(0, 5.0, 0.05)
    phi = 2.0 * t
    dr = dead_reckon(t, phi, phi, DiffDriveParams(0.05, 0.05, 0.3), scheme="paper")
    assert dr.x[-1] == pytest.approx(0.05 * phi[-1])
    assert np.all(dr.y == 0)
