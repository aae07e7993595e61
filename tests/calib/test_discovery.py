"""Unit checks of discovery's parts against closed forms and the simulator, plus the small
null study (the full one is bench/discovery_null_study.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import polars as pl
import pytest
from discovery_logs import ISSUE_CATALOGUE
from discovery_simruns import null_study  # type: ignore[import-not-found]
from sim_frame import aligned_frame_from_run  # type: ignore[import-not-found]

from calib.discovery.sparse import stlsq
from calib.errors import InsufficientDataError
from calib.tractor_trailer.discovery import catalogue, discover
from calib.tractor_trailer.discovery.data import CommandSignal, prepare_data
from calib.tractor_trailer.discovery.diagnostics import ljung_box
from calib.tractor_trailer.discovery.effects.actuator_lag import first_order_lag
from calib.tractor_trailer.discovery.model import (
    ModelSpec,
    as_recorded,
    integrate_hitch_half,
    predict,
)
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    NoiseSpec,
    SimulatedRun,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)


def test_stlsq_recovers_the_sparse_terms() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=(600, 6))
    y = 2.0 * x[:, 0] - 0.5 * x[:, 3] + rng.normal(0, 0.05, 600)
    coef = stlsq(x, y, threshold=0.05)
    assert np.count_nonzero(coef) == 2
    assert coef[0] == pytest.approx(2.0, abs=0.02)
    assert coef[3] == pytest.approx(-0.5, abs=0.02)


def test_ljung_box_white_and_correlated() -> None:
    rng = np.random.default_rng(2)
    e = rng.normal(size=2000)
    _, p_white = ljung_box(e)
    ar = np.zeros_like(e)
    for i in range(1, e.size):
        ar[i] = 0.5 * ar[i - 1] + e[i]
    q, p_ar = ljung_box(ar, lags=1)
    # lag-1 only: Q = n (n + 2) rho^2 / (n - 1), rho ~ 0.5
    assert p_white > 1e-3
    assert p_ar < 1e-12
    assert q == pytest.approx(2000 * 2002 * 0.25 / 1999, rel=0.15)


def test_command_signal_is_linear_but_keeps_steps() -> None:
    t = np.arange(0, 1.0001, 0.01)
    ramp = CommandSignal.from_samples(t, 0.3 * t)
    tq = np.array([0.123, 0.5, 0.777])
    assert np.allclose(ramp.integral(tq), 0.15 * tq**2)
    step = CommandSignal.from_samples(t, np.where(t >= 0.5, 0.2, 0.0))
    # a jump between two samples is a jump, not a ramp, at their midpoint (its expected place;
    # ``at`` averages over a window of 1/50 of the period, centred)
    assert step.at(np.array([0.49, 0.4948]))[1] == 0.0
    assert step.at(np.array([0.4952, 0.5]))[0] == pytest.approx(0.2)
    # the integral is exact: 0.2 * (0.8 - 0.495)
    assert step.integral(np.array([0.8]))[0] == pytest.approx(0.061)


def test_command_window_makes_a_held_jump_continuous_in_a_time_shift() -> None:
    """Averaged over a window of one grid step, a held jump moves smoothly with a shift: a
    dead time fitted across step commands has a gradient (with point samples it had none)."""
    t = np.arange(0, 1.0001, 0.01)
    step = CommandSignal.from_samples(t, np.where(t >= 0.5, 0.2, 0.0), window_s=0.01)
    shifts = np.array([0.0, 0.002, 0.004])
    vals = np.array([step.at(np.array([0.495 - d]))[0] for d in shifts])
    # the jump is at 0.495; the window [0.49 - d, 0.5 - d] holds the new value over 0.005 - d
    assert np.allclose(vals, 0.2 * (0.005 - shifts) / 0.01)


def test_first_order_lag_step_response() -> None:
    t = np.arange(0, 5.0, 0.01)
    x = np.ones_like(t)
    x[0] = 0.0
    tau, h = 0.4, 0.01
    y = first_order_lag(t, x, tau)
    # the input rises linearly over the first interval, then holds: exact solution
    # y = 1 - (tau / h)(exp(h / tau) - 1) exp(-t / tau) for t >= h
    expected = 1.0 - (tau / h) * np.expm1(h / tau) * np.exp(-t / tau)
    assert np.max(np.abs(y[1:] - expected[1:])) < 1e-12


def test_first_order_lag_is_exact_for_lags_of_a_few_steps_on_any_grid() -> None:
    """A lag of two grid steps on a jittered grid, against the closed-form response to a
    ramp input (x = t: y = t - tau (1 - exp(-t / tau)) from y(0) = 0); a trapezoidal hold is
    off by several per cent of tau here and a dead time then fits better than the lag."""
    rng = np.random.default_rng(3)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.005, 0.015, 400))])
    tau = 0.02
    y = first_order_lag(t, t.copy(), tau)
    assert np.max(np.abs(y - (t - tau * (1.0 - np.exp(-t / tau))))) < 1e-12
    # a step longer than any chunk of the closed-form sum: no overflow
    t2 = np.array([0.0, 1.0, 2.0])
    assert np.allclose(first_order_lag(t2, np.array([0.0, 1.0, 1.0]), 1e-3), [0, 1 - 1e-3, 1])


def _smooth_run(**kw: object) -> SimulatedRun:
    cmds = CommandSequence([CommandSpec(CommandType.HARMONIC, 60.0, 0.2, 0.2)])
    cfg = TractorTrailerSim(commands=cmds, speed=SpeedProfile(1.0), **kw)  # type: ignore[arg-type]
    return simulate_tractor_trailer(cfg, seed=3)


def test_hitch_dynamics_match_the_simulator() -> None:
    """Independent truth: the simulator's RK4 of the transient kinematics, noise-free."""
    run = _smooth_run(noise=NoiseSpec.none())
    data = prepare_data(aligned_frame_from_run(run))
    psi = integrate_hitch_half(data.th_s, data.kappa_h, data.v_h, 1.25, 2.48, 2.48, data.psi0)
    truth = run.truth["psi"].to_numpy()
    # the command is averaged over one grid step, centred: no lead, |d2psi/dt2| small
    assert np.max(np.abs(psi - truth[: psi.size])) < 2e-5


def test_restart_takes_the_sensor_effects_out_of_the_recorded_angle() -> None:
    """Where the joint-angle model restarts from the recorded angle (reversing, gaps), that
    angle holds the sensor's offset and gain: the model must restart from the true angle, so
    that the modelled recording at the restart is the recorded value again (not offset
    twice)."""
    run = _smooth_run(noise=NoiseSpec.none())
    data = prepare_data(aligned_frame_from_run(run))
    row, rec = 500, 0.1
    data = replace(data, anchors={row: rec})
    pool = {e.key: e for e in catalogue("transient")}
    spec = ModelSpec("transient", (pool["sensor_scale(psi)"], pool["sensor_offset(psi)"]))
    pred = predict(spec, [1.25, 2.48, 1.1, 0.03], data, full_rate=True)
    assert pred["psi"][row] == pytest.approx(rec, abs=1e-12)


def test_slow_output_is_modelled_as_the_log_records_it() -> None:
    """A 10 Hz yaw rate linearly interpolated onto a 50 Hz grid: the model is sampled at the
    topic's own stamps and interpolated the same way (a jump becomes the same ramp); a topic
    held between its samples is not taken for interpolated."""
    t_ns = np.arange(0, 30_000_000_000, 20_000_000, dtype=np.int64)
    t_raw = np.arange(0, 30_000_000_000, 100_000_000, dtype=np.int64)

    def true_omega(t: np.ndarray) -> np.ndarray:
        return np.where(t >= 12.34e9, 0.2, 0.05) + 0.01 * np.sin(t / 1e9)

    raw = pl.DataFrame({"t_ns": t_raw, "value": true_omega(t_raw.astype(float))})
    ramped = np.interp(t_ns.astype(float), t_raw.astype(float), raw["value"].to_numpy())
    frame = pl.DataFrame(
        {"t_ns": t_ns, "kappa_cmd": np.zeros(t_ns.size), "v": np.ones(t_ns.size), "omega": ramped}
    )
    data = prepare_data(frame, {"omega": raw})
    assert data.sampled["omega"] == pytest.approx(t_raw / 1e9)
    modelled = true_omega(t_ns.astype(float))  # the truth at every row: a sharp jump
    assert np.abs(modelled - ramped).max() > 0.05
    assert np.allclose(as_recorded(data, "omega", modelled), ramped, atol=1e-12)
    held = raw["value"].to_numpy()[np.searchsorted(t_raw, t_ns, side="right") - 1]
    data_held = prepare_data(frame.with_columns(omega=held), {"omega": raw})
    assert "omega" not in data_held.sampled


def test_steady_baseline_is_the_patent_relation() -> None:
    run = _smooth_run(noise=NoiseSpec.none(), hitch_model="steady")
    data = prepare_data(aligned_frame_from_run(run))
    pred = predict(ModelSpec("steady"), [1.25, 2.48], data, full_rate=True)
    kappa = run.truth["kappa"].to_numpy()[: data.t_s.size]
    # the command is averaged over one grid step, centred (the end rows average in the value
    # held outside the log)
    want = steady_state_psi(kappa, 1.25, 2.48)
    assert np.allclose(pred["psi"][1:-1], want[1:-1], atol=2e-5)
    assert np.allclose(pred["omega"][1:-1], data.outputs["omega"][1:-1], atol=1e-5)


def test_missing_columns_and_short_logs_are_reported() -> None:
    frame = pl.DataFrame({"t_ns": np.arange(10) * 10_000_000, "kappa_cmd": np.zeros(10)})
    with pytest.raises(InsufficientDataError, match="lacks column"):
        prepare_data(frame)
    frame = frame.with_columns(v=pl.lit(1.0), psi=pl.lit(0.0))
    with pytest.raises(InsufficientDataError, match="fitting samples"):
        prepare_data(frame)


def test_catalogue_is_one_interface() -> None:
    steady = catalogue("steady")
    assert {e.id for e in steady} == ISSUE_CATALOGUE
    assert "hitch_transient" not in {e.id for e in catalogue("transient")}
    assert {e.key for e in catalogue("steady", ("omega",))}.isdisjoint(
        {"hitch_transient", "sensor_offset(psi)", "clock_offset(hitch)"}
    )
    for e in steady:
        values = {p.name: p.init for p in e.params}
        assert e.params
        assert e.explanation(values)
        assert set(e.channels) <= {"omega", "psi"}


def test_yaw_rate_from_kappa_column() -> None:
    run = _smooth_run()
    frame = aligned_frame_from_run(run).drop("omega")
    data = prepare_data(frame.filter(pl.col("kappa").is_not_nan()))
    assert "omega" in data.outputs


@pytest.mark.slow  # about 10-25 s: eight logs through selection and confirmation
def test_null_study_small() -> None:
    """8 logs with nothing beyond the baseline's physics (4 steady, 4 transient): at most one
    false report (the 40-log study in bench/ asks >= 38 of 40)."""
    res = null_study(8, seed=11, duration_s=70.0)
    assert res.n_quiet >= 7, res.reported


@pytest.mark.slow
def test_near_steady_run_is_quiet_against_the_steady_baseline() -> None:
    """Transient physics, but curvature that changes so slowly per metre that the joint angle
    stays within a third of the sensor noise of the steady state: nothing to report."""
    cmds = CommandSequence(
        [
            CommandSpec(CommandType.CONSTANT, 30.0, 0.1),
            CommandSpec(CommandType.LINEAR, 60.0, -0.1, 0.005),
        ]
    )
    cfg = TractorTrailerSim(commands=cmds, speed=SpeedProfile(1.5, ramp_s=0.5))
    run = simulate_tractor_trailer(cfg, seed=5)
    truth = run.truth
    lag = truth["psi"].to_numpy() - steady_state_psi(truth["kappa"].to_numpy(), 1.25, 2.48)
    assert np.max(np.abs(lag[1000:])) < 0.005 / 3  # precondition: near steady state
    res = discover(aligned_frame_from_run(run), 1.25, 2.48, baseline="steady")
    assert res.effect("hitch_transient") is None
    assert res.effects == [], [e.label for e in res.effects]


def test_yaw_rate_only_log() -> None:
    """Without a joint-angle sensor the catalogue shrinks to effects on the yaw rate."""
    cmds = CommandSequence(
        [
            CommandSpec(CommandType.HARMONIC, 40.0, 0.2, 0.25),
            CommandSpec(CommandType.STEP, 30.0, 0.15),
        ]
    )
    cfg = TractorTrailerSim(
        commands=cmds,
        speed=SpeedProfile(1.0, variation=0.3),  # else a gain and understeer look the same
        effects=Effects(sensor_scale={"omega": 0.95}),
    )
    run = simulate_tractor_trailer(cfg, seed=8)
    frame = aligned_frame_from_run(run).drop("psi")
    res = discover(frame, 1.25, 2.48)
    assert [e.label for e in res.effects] == ["sensor_scale(omega)"]
    lo, hi = res.effects[0].ci95["scale"]
    assert lo <= 0.95 <= hi
    assert set(res.rms_baseline) == {"omega"}


def test_command_integral_finds_each_querys_interval_as_searchsorted_does() -> None:
    # the interval lookup goes through np.interp of knot positions; it must agree with
    # searchsorted(side="right") - 1, repeated sample times and queries on knots included
    from calib.tractor_trailer.discovery.data import CommandSignal

    rng = np.random.default_rng(0)
    for _ in range(100):
        n = int(rng.integers(3, 200))
        t = np.cumsum(rng.choice([0.0, 0.01, 0.02, 0.013], n))
        cs = CommandSignal.from_samples(t, np.round(rng.normal(size=n), 1))
        tk = cs.t_s
        tq = np.sort(np.concatenate([rng.uniform(tk[0] - 1, tk[-1] + 1, 300), tk]))
        i = np.clip(np.searchsorted(tk, tq, side="right") - 1, 0, tk.size - 2)
        tau = np.clip(tq, tk[0], tk[-1]) - tk[i]
        inside = cs.cum[i] + cs.y[i] * tau + 0.5 * cs.slope[i] * tau * tau
        before = (tq - tk[0]) * cs.y[0]
        after = cs.cum[-1] + (tq - tk[-1]) * cs.y[-1]
        ref = np.where(tq < tk[0], before, np.where(tq > tk[-1], after, inside))
        np.testing.assert_allclose(cs.integral(tq), ref, rtol=0, atol=1e-12)
