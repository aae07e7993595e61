"""The ICR slip of a skid steer (the gain growing jointly with speed and turn rate) on simulated
odometry + gyro logs: named when the simulator switches it on, its parameters recovered, not
confused with the single-covariate growths; nested effects are not fitted together."""

from __future__ import annotations

import numpy as np
import pytest

from calib.diff_drive.odom_imu import analyze_odom_imu
from calib.diff_drive.odom_imu.effects import ICR_SLIP, TURN_SLIP
from calib.diff_drive.odom_imu.fitter import GainFitter
from calib.diff_drive.odom_imu.windows import windows
from calib.diff_drive.sim import OdomImuSimConfig, simulate_odom_imu
from calib.discovery import CandidateFailedError


def test_icr_slip_is_detected_on_a_simulated_log() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2, icr_turn=0.2, icr_joint=0.8), seed=1)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    assert "icr_slip" in r.named
    assert "turn_slip" not in r.named
    assert "speed_slip" not in r.named
    assert r.selection is not None
    icr = r.selection.final.effect_parameters[ICR_SLIP.key]
    assert icr["per_rad_s"].value == pytest.approx(0.2, abs=0.03)
    assert icr["per_m_rad"].value == pytest.approx(0.8, abs=0.05)


def test_icr_slip_is_not_named_on_a_constant_gain() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2), seed=1)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    assert r.named == ["effective_track"]


def test_the_simulator_switch_makes_the_gain_grow_jointly() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.0, icr_joint=1.0), seed=0)
    expect = 1 + np.abs(sim.odom_v) * np.abs(sim.omega_true * sim.gain)
    assert np.allclose(sim.gain, expect)


def test_nested_effects_are_not_fitted_together() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.1), seed=0)
    w = windows(sim.t, sim.odom_omega, sim.gyro_z, sim.odom_v)
    use = np.flatnonzero(w.rate >= 0.05).astype(np.intp)
    fitter = GainFitter(w, use, 0.02)
    with pytest.raises(CandidateFailedError, match="nested"):
        fitter((TURN_SLIP, ICR_SLIP))
