"""Simulator checks against independent truth: closed forms and a tight-tolerance ODE solve."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from calib.tractor_trailer.models.hitch_kinematics import (
    psi_rate,
    steady_state_psi,
    steady_state_residual,
)
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    SENSOR_GROUPS,
    Effects,
    NoiseSpec,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)

CONST_V = SpeedProfile(v_mps=1.0, ramp_s=0.0)


def _cfg(specs: list[CommandSpec], **kw: object) -> TractorTrailerSim:
    base: dict[str, object] = {
        "commands": CommandSequence(specs),
        "speed": CONST_V,
        "noise": NoiseSpec.none(),
    }
    base.update(kw)
    return TractorTrailerSim(**base)  # type: ignore[arg-type]


def _reference(cfg: TractorTrailerSim, t: np.ndarray) -> np.ndarray:
    """Full state [x, y, yaw, psi, kappa_lag] by solve_ivp (DOP853, rtol 1e-11)."""
    eff = cfg.effects
    tau = eff.actuator_lag_s

    def rhs(ts: float, s: np.ndarray) -> list[float]:
        k_in = float(cfg.commands(ts - eff.actuator_delay_s)[0])
        v = float(cfg.speed(np.array([ts]))[0])
        k_act = s[4] if tau > 0 else k_in
        k = k_act / (1.0 + eff.understeer_K * v * v)
        dk = (k_in - s[4]) / tau if tau > 0 else 0.0
        dpsi = float(psi_rate(v, k, s[3], cfg.L1, cfg.L2))
        return [v * np.cos(s[2]), v * np.sin(s[2]), v * k, dpsi, dk]

    k0 = float(cfg.commands(-eff.actuator_delay_s)[0])
    sol = solve_ivp(
        rhs, (t[0], t[-1]), [0, 0, 0, 0, k0], method="DOP853", t_eval=t, rtol=1e-11, atol=1e-12
    )
    return sol.y.T


@pytest.mark.parametrize(
    "effects",
    [
        Effects(),
        Effects(actuator_lag_s=0.4, understeer_K=0.05, actuator_delay_s=0.3),
    ],
)
def test_matches_fine_reference_solution(effects: Effects) -> None:
    spec = CommandSpec(CommandType.HARMONIC, 63.0, amplitude=0.2, rate=0.1)
    cfg = _cfg(
        [spec],
        effects=effects,
        speed=SpeedProfile(v_mps=1.2, ramp_s=2.0, variation=0.3, period_s=20.0),
    )
    run = simulate_tractor_trailer(cfg)
    truth = run.truth
    t = (truth["t_ns"].to_numpy() - cfg.start_time_ns) * 1e-9
    ref = _reference(cfg, t)
    for i, name in enumerate(["x", "y", "yaw", "psi"]):
        err = np.max(np.abs(truth[name].to_numpy() - ref[:, i]))
        assert err < 1e-8, (name, err)


def test_constant_kappa_closed_form_path_and_steady_psi() -> None:
    kappa, L1, L2 = 0.15, 1.25, 2.48
    run = simulate_tractor_trailer(_cfg([CommandSpec(CommandType.CONSTANT, 60.0, kappa)]))
    tr = run.truth
    t = (tr["t_ns"].to_numpy() - run.config.start_time_ns) * 1e-9
    np.testing.assert_allclose(tr["yaw"].to_numpy(), kappa * t, atol=1e-12)
    np.testing.assert_allclose(tr["x"].to_numpy(), np.sin(kappa * t) / kappa, atol=1e-9)
    np.testing.assert_allclose(tr["y"].to_numpy(), (1 - np.cos(kappa * t)) / kappa, atol=1e-9)
    # After 60 m (about 24 relaxation lengths) psi sits on the steady state.
    psi_ss = float(steady_state_psi(kappa, L1, L2))
    assert tr["psi"][-1] == pytest.approx(psi_ss, abs=1e-8)


@pytest.mark.parametrize("L2", [1.5, 3.0])
def test_relaxation_distance_scales_with_L2(L2: float) -> None:
    """Linearised about the rest point, psi relaxes over lambda = L2 / (cos psi* + k L1 sin psi*)
    metres; with a small step in kappa the 1/e distance matches it."""
    kappa, L1 = 0.01, 1.0
    run = simulate_tractor_trailer(
        _cfg([CommandSpec(CommandType.CONSTANT, 8 * L2, kappa)], L1=L1, L2=L2, rate_hz=200.0)
    )
    s = (run.truth["t_ns"].to_numpy() - run.config.start_time_ns) * 1e-9  # v = 1 m/s
    psi = run.truth["psi"].to_numpy()
    psi_ss = float(steady_state_psi(kappa, L1, L2))
    lam = L2 / (np.cos(psi_ss) + kappa * L1 * np.sin(psi_ss))
    # Far enough from the start the gap psi_ss - psi decays like exp(-s / lam).
    gap = psi_ss - psi
    i1, i2 = np.searchsorted(s, [lam, 3 * lam])
    ratio = gap[i1] / gap[i2]
    fitted = (s[i2] - s[i1]) / np.log(ratio)
    assert fitted == pytest.approx(lam, rel=5e-3)


def test_steady_hitch_model_satisfies_steady_relation_exactly() -> None:
    spec = CommandSpec(CommandType.HARMONIC, 63.0, amplitude=0.2, rate=0.1)
    run = simulate_tractor_trailer(_cfg([spec], hitch_model="steady"))
    tr = run.truth
    res = steady_state_residual(tr["kappa"].to_numpy(), tr["psi"].to_numpy(), 1.25, 2.48)
    assert np.max(np.abs(res)) < 1e-14


def test_delay_is_the_shifted_command() -> None:
    spec = CommandSpec(CommandType.HARMONIC, 63.0, amplitude=0.2, rate=0.1)
    d = 0.7
    run = simulate_tractor_trailer(_cfg([spec], effects=Effects(actuator_delay_s=d)))
    tr = run.truth
    t = (tr["t_ns"].to_numpy() - run.config.start_time_ns) * 1e-9
    expected = np.where(t >= d, 0.2 * np.sin(0.1 * (t - d)), 0.0)
    np.testing.assert_allclose(tr["kappa"].to_numpy(), expected, atol=1e-15)
    np.testing.assert_allclose(tr["kappa_cmd"].to_numpy(), 0.2 * np.sin(0.1 * t), atol=1e-15)


def test_lag_is_first_order_step_response() -> None:
    m, tau, at = 0.1, 0.5, 5.0
    spec = CommandSpec(CommandType.STEP, 10.0, amplitude=m, step_at_s=at)
    run = simulate_tractor_trailer(_cfg([spec], effects=Effects(actuator_lag_s=tau)))
    tr = run.truth
    t = (tr["t_ns"].to_numpy() - run.config.start_time_ns) * 1e-9
    expected = np.where(t >= at, m * (1 - np.exp(-(t - at) / tau)), 0.0)
    # The step is sampled: its edge is smeared over one half step h = 5 ms.
    np.testing.assert_allclose(tr["kappa"].to_numpy(), expected, atol=m * 0.005 / tau)
    assert tr["kappa"][-1] == pytest.approx(m * (1 - np.exp(-5.0 / tau)), rel=1e-3)


def test_understeer_scales_curvature() -> None:
    K, v = 0.2, 1.5
    spec = CommandSpec(CommandType.CURVE, 30.0, amplitude=0.2, rate=0.1)
    run = simulate_tractor_trailer(
        _cfg([spec], speed=SpeedProfile(v_mps=v, ramp_s=0.0), effects=Effects(understeer_K=K))
    )
    tr = run.truth
    np.testing.assert_allclose(
        tr["kappa"].to_numpy(), tr["kappa_cmd"].to_numpy() / (1 + K * v * v), rtol=1e-14
    )
    np.testing.assert_allclose(tr["omega"].to_numpy(), v * tr["kappa"].to_numpy(), rtol=1e-14)


def test_sensor_offset_scale_and_clock_offset() -> None:
    spec = CommandSpec(CommandType.HARMONIC, 20.0)
    eff = Effects(
        sensor_offset={"psi": 0.03, "v": -0.1},
        sensor_scale={"omega": 1.1},
        clock_offset_s={"hitch": 0.25},
    )
    run = simulate_tractor_trailer(_cfg([spec], effects=eff))
    tr = run.truth
    hitch, odom = run.frames["hitch"], run.frames["odom"]
    shift = 250_000_000
    np.testing.assert_array_equal(hitch["t_ns"].to_numpy(), tr["t_ns"].to_numpy() + shift)
    np.testing.assert_array_equal(odom["t_ns"].to_numpy(), tr["t_ns"].to_numpy())
    np.testing.assert_allclose(hitch["psi"].to_numpy(), tr["psi"].to_numpy() + 0.03, atol=1e-15)
    np.testing.assert_allclose(odom["v"].to_numpy(), tr["v"].to_numpy() - 0.1, atol=1e-15)
    np.testing.assert_allclose(odom["omega"].to_numpy(), 1.1 * tr["omega"].to_numpy())
    assert run.params["sensor_offset.psi"] == 0.03
    assert run.params["clock_offset_s.hitch"] == 0.25


def test_noise_has_the_specified_std_and_groups_their_rates() -> None:
    spec = CommandSpec(CommandType.HARMONIC, 100.0)
    noise = NoiseSpec(std={"psi": 0.02, "x": 0.05})
    run = simulate_tractor_trailer(_cfg([spec], noise=noise), seed=3)
    tr = run.truth
    d_psi = run.frames["hitch"]["psi"].to_numpy() - tr["psi"].to_numpy()
    assert np.std(d_psi) == pytest.approx(0.02, rel=0.05)
    pose = run.frames["pose"]
    assert pose.height == (tr.height - 1) // 2 + 1  # 50 Hz of 100 Hz
    d_x = pose["x"].to_numpy() - tr["x"].to_numpy()[::2]
    assert np.std(d_x) == pytest.approx(0.05, rel=0.05)
    np.testing.assert_array_equal(pose["y"].to_numpy(), tr["y"].to_numpy()[::2])
    assert {g: tuple(f.columns[1:]) for g, f in run.frames.items()} == SENSOR_GROUPS


def test_same_seed_same_run_and_jitter_off_by_default() -> None:
    cfg = _cfg([CommandSpec(CommandType.HARMONIC, 10.0)], noise=NoiseSpec())
    a, b = simulate_tractor_trailer(cfg, seed=7), simulate_tractor_trailer(cfg, seed=7)
    for g in a.frames:
        assert a.frames[g].equals(b.frames[g])
    grid = a.truth["t_ns"].to_numpy()
    np.testing.assert_array_equal(a.frames["odom"]["t_ns"].to_numpy(), grid)
    assert a.seed == 7


def test_timestamp_jitter() -> None:
    cfg = _cfg([CommandSpec(CommandType.HARMONIC, 100.0)], timestamp_jitter_s=0.001)
    run = simulate_tractor_trailer(cfg, seed=1)
    d = (run.frames["odom"]["t_ns"].to_numpy() - run.truth["t_ns"].to_numpy()) * 1e-9
    assert np.std(d) == pytest.approx(0.001, rel=0.05)
    assert np.max(np.abs(d)) <= 0.45 * 0.01 + 1e-9
    assert np.all(np.diff(run.frames["odom"]["t_ns"].to_numpy()) > 0)
    # values are those at the nominal time
    np.testing.assert_array_equal(run.frames["odom"]["v"].to_numpy(), run.truth["v"].to_numpy())


def test_empty_commands_rejected() -> None:
    with pytest.raises(ValueError, match="commands is empty"):
        simulate_tractor_trailer(TractorTrailerSim())
