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
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2, icr_turn=0.1, icr_joint=0.15), seed=1)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    assert "icr_slip" in r.named
    assert "turn_slip" not in r.named
    assert "speed_slip" not in r.named
    assert r.selection is not None
    icr = r.selection.final.effect_parameters[ICR_SLIP.key]
    assert icr["per_rad_s"].value == pytest.approx(0.1, abs=0.02)
    assert icr["per_m_rad"].value == pytest.approx(0.15, abs=0.02)


def test_icr_slip_is_not_named_on_a_constant_gain() -> None:
    # the ICR model holds a constant gain (a = c = 0): a constant is named as the constant
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2), seed=1)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    assert r.named == ["effective_track"]


def test_the_simulator_switch_makes_the_gain_grow_jointly() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.0, icr_joint=0.5), seed=0)
    odometry_rate = sim.omega_true * sim.gain  # without the odometry's noise
    expect = 1 / (1 - 0.5 * np.abs(sim.odom_v) * np.abs(odometry_rate))
    assert np.allclose(sim.gain, expect)
    assert float(np.max(sim.gain)) > 1.2  # the switch does something on this log


def test_nested_effects_are_not_fitted_together() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.1), seed=0)
    w = windows(sim.t, sim.odom_omega, sim.gyro_z, sim.odom_v)
    use = np.flatnonzero(w.rate >= 0.05).astype(np.intp)
    fitter = GainFitter(w, use, 0.02)
    with pytest.raises(CandidateFailedError, match="nested"):
        fitter((TURN_SLIP, ICR_SLIP))


def test_after_discovery_the_gain_is_re_estimated_under_the_law() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2, icr_turn=0.1, icr_joint=0.15), seed=2)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    assert r.adequacy.verdict == "does not explain"  # a constant gain does not
    assert r.final_adequacy.verdict == "explains"  # the law does
    g = r.recommended_gain()
    assert g.identifiable
    # the turn-weighted mean of the true gain over the samples that turn
    turn = np.abs(sim.odom_omega) >= 0.05
    true_mean = np.sum(np.abs(sim.odom_omega[turn])) / np.sum(np.abs(sim.omega_true[turn]))
    assert g.value == pytest.approx(true_mean, rel=0.01)
    pars = r.law_parameters()
    assert {"icr_slip.per_rad_s", "icr_slip.per_m_rad", "yaw_rate_gain_slow_turn"} <= set(pars)
    assert pars["yaw_rate_gain_slow_turn"].value == pytest.approx(1.2, abs=0.02)


def test_a_gain_outside_the_catalogue_is_described() -> None:
    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2), seed=1)
    # a gyro reading that differs between left and right turns: no catalogue effect has it
    gyro = sim.gyro_z + 0.08 * np.abs(sim.omega_true)
    r = analyze_odom_imu(sim.t, sim.odom_omega, gyro, odom_v=sim.odom_v)
    assert r.explained is not None
    d = r.explained.description
    assert d is not None
    assert d.accepted
    assert [t.term.name for t in d.terms] == ["|omega|"]
    # 0.08 |true rate| = 0.08 / 1.2 |odometry rate|
    assert d.terms[0].coefficient.value == pytest.approx(0.08 / 1.2, rel=0.05)
    assert r.final_adequacy.verdict == "explains"
    assert r.recommended_gain().value == pytest.approx(1.2, abs=0.01)
    # the selection had named icr_slip for what the described term explains: once the term is
    # kept, the ICR model is replaced by the constant gain it contains, and a note says so
    assert r.named == ["effective_track"]
    assert any("icr_slip(track) replaced by effective_track(track)" in n for n in r.notes)


def test_the_discovery_report_has_the_shared_shape() -> None:
    from calib.diff_drive.odom_imu.report import odom_imu_discovery_report

    sim = simulate_odom_imu(OdomImuSimConfig(gain=1.2, icr_turn=0.1, icr_joint=0.15), seed=1)
    r = analyze_odom_imu(sim.t, sim.odom_omega, sim.gyro_z, odom_v=sim.odom_v)
    doc = odom_imu_discovery_report(r).to_dict()
    assert doc["engine"] == "calib.discovery"
    assert doc["named"] == ["icr_slip(track)"]  # G0 is the ICR model's own
    assert doc["verdict_after"]["verdict"] == "explains"
    assert doc["moved"]["yaw_rate_gain"]["after"]["identifiable"] is True
    assert doc["details"]["law"]["verdict"] == "explains"
