"""Simulator of the tractor + off-axle trailer driven by curvature commands.

Physics: the commanded curvature passes through the actuator (optional dead time, first-order
lag, understeer), C1 moves at speed v along that curvature, and the joint angle follows the
transient off-axle kinematics d psi/dt = v kappa - (v sin psi - L1 v kappa cos psi)/L2
(or, with ``hitch_model="steady"``, the patent's steady-state relation). Sensors sample the
truth per group at their own rates, with Gaussian noise, optional bias/scale, clock offsets
and timestamp jitter.

Sensor groups and the logical signals they carry (see LOG_FORMAT.md):
``cmd`` (kappa_cmd, v_cmd), ``odom`` (v, omega), ``pose`` (x, y, yaw), ``hitch`` (psi).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import polars as pl
from scipy.signal import lfilter

from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.models.hitch_rk4 import rk4_hitch
from calib.tractor_trailer.results import Segment
from calib.tractor_trailer.sim.choices import HitchModel
from calib.tractor_trailer.sim.commands import CommandSequence
from calib.tractor_trailer.sim.validation import (
    SimParameterError,
    check_finite,
    check_non_negative,
    check_positive,
    check_steady_turn,
    require,
)

__all__ = [
    "SENSOR_GROUPS",
    "Effects",
    "HitchModel",
    "NoiseSpec",
    "SimParameterError",
    "SimulatedRun",
    "SpeedProfile",
    "TractorTrailerSim",
    "simulate_tractor_trailer",
]

SENSOR_GROUPS: dict[str, tuple[str, ...]] = {
    "cmd": ("kappa_cmd", "v_cmd"),
    "odom": ("v", "omega"),
    "pose": ("x", "y", "yaw"),
    "hitch": ("psi",),
}


@dataclass(frozen=True)
class SpeedProfile:
    """Forward speed of C1 (m/s): ramps from 0 to ``v_mps`` over ``ramp_s`` seconds, then
    ``v_mps * (1 + variation * sin(2 pi t / period_s))``."""

    v_mps: float = 1.0
    ramp_s: float = 2.0
    variation: float = 0.0
    period_s: float = 40.0

    def __post_init__(self) -> None:
        check_positive("v_mps", self.v_mps, "m/s, driving forward")
        check_non_negative("ramp_s", self.ramp_s, "s")
        check_finite("variation", self.variation)
        require(abs(self.variation) < 1, "variation", self.variation, "|variation| < 1")
        check_positive("period_s", self.period_s, "s")

    @property
    def max_mps(self) -> float:
        """Largest speed of the profile (m/s)."""
        return self.v_mps * (1.0 + abs(self.variation))

    def __call__(self, t_s: np.ndarray) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        ramp = np.clip(t / self.ramp_s, 0.0, 1.0) if self.ramp_s > 0 else np.ones_like(t)
        return self.v_mps * ramp * (1.0 + self.variation * np.sin(2 * np.pi * t / self.period_s))


@dataclass(frozen=True)
class NoiseSpec:
    """Standard deviations of white Gaussian sensor noise, per logical signal (SI units)."""

    std: Mapping[str, float] = field(
        default_factory=lambda: {
            "kappa_cmd": 0.0,
            "v_cmd": 0.0,
            "v": 0.01,
            "omega": 0.002,
            "x": 0.01,
            "y": 0.01,
            "yaw": 0.002,
            "psi": 0.005,
        }
    )

    def __post_init__(self) -> None:
        for name, sd in self.std.items():
            check_non_negative(f"noise.std[{name}]", sd)

    @classmethod
    def none(cls) -> NoiseSpec:
        return cls(std={})


@dataclass(frozen=True)
class Effects:
    """Physics beyond the baseline, injected into the simulation (all off by default).

    Args:
        actuator_delay_s: dead time between command and curvature (s).
        actuator_lag_s: time constant of a first-order lag on curvature (s).
        understeer_K: kappa = kappa_act / (1 + K v^2), K in s^2/m^2.
        sensor_offset: constant bias added to a measured signal, by signal name (SI units).
        sensor_scale: gain applied to a measured signal, by signal name.
        clock_offset_s: shift added to a sensor group's timestamps (s), by group name.
    """

    actuator_delay_s: float = 0.0
    actuator_lag_s: float = 0.0
    understeer_K: float = 0.0
    sensor_offset: Mapping[str, float] = field(default_factory=dict)
    sensor_scale: Mapping[str, float] = field(default_factory=dict)
    clock_offset_s: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_non_negative("actuator_delay_s", self.actuator_delay_s, "s")
        check_non_negative("actuator_lag_s", self.actuator_lag_s, "s")
        check_finite("understeer_K", self.understeer_K, "s^2/m^2")
        for what, values in (
            ("sensor_offset", self.sensor_offset),
            ("sensor_scale", self.sensor_scale),
            ("clock_offset_s", self.clock_offset_s),
        ):
            for name, value in values.items():
                check_finite(f"{what}[{name}]", value)


@dataclass(frozen=True)
class TractorTrailerSim:
    """Configuration of one simulated run.

    Args:
        L1, L2: link lengths (m).
        commands: curvature command sequence.
        speed: speed profile.
        noise: sensor noise.
        effects: injected effects.
        hitch_model: :class:`HitchModel` (or its string value).
        rate_hz: integration and base sampling rate (Hz).
        rates_hz: per sensor group sampling rate (Hz); must divide ``rate_hz``.
        start_time_ns: absolute time of t = 0 (ns since the Unix epoch).
        timestamp_jitter_s: standard deviation of white Gaussian jitter on each sample's
            timestamp (s), clipped to +/- 0.45 of the group's sample period; the value stays
            the one at the nominal time (the sensor stamps late or early). 0: none; must be
            below the fastest sample period, so stamps stay strictly increasing per topic.

    Raises:
        SimParameterError: a parameter that makes no physical sense: a non-finite number, a
            rate, ``L2`` or duration <= 0, no steady turn at the command's peak curvature
            (kappa^2 >= 1/(L2^2 - L1^2)), a jitter outside [0, sample period), a rate too coarse
            for the hitch dynamics. ``L1`` may be 0 or negative (a hitch ahead of the tractor
            axle); the presets also require ``|L1| < L2``.
    """

    L1: float = 1.25
    L2: float = 2.48
    commands: CommandSequence = field(default_factory=lambda: CommandSequence([]))
    speed: SpeedProfile = field(default_factory=SpeedProfile)
    noise: NoiseSpec = field(default_factory=NoiseSpec)
    effects: Effects = field(default_factory=Effects)
    hitch_model: HitchModel | Literal["transient", "steady"] = HitchModel.TRANSIENT
    rate_hz: float = 100.0
    rates_hz: Mapping[str, float] = field(
        default_factory=lambda: {"cmd": 100.0, "odom": 100.0, "pose": 50.0, "hitch": 100.0}
    )
    start_time_ns: int = 1_750_000_000_000_000_000
    timestamp_jitter_s: float = 0.0

    def __post_init__(self) -> None:
        """Reject parameters that make no physical sense (:class:`SimParameterError`)."""
        choices = [h.value for h in HitchModel]
        require(
            self.hitch_model in choices,
            "hitch_model",
            self.hitch_model,
            f"one of {', '.join(choices)}",
        )
        check_positive("L2", self.L2, "m")
        check_finite("L1", self.L1, "m")
        check_positive("rate_hz", self.rate_hz, "Hz")
        for group, r in self.rates_hz.items():
            check_positive(f"rates_hz[{group}]", r, "Hz")
        rates = [self.rate_hz, *(self.rates_hz.get(g, self.rate_hz) for g in SENSOR_GROUPS)]
        period_s = 1.0 / max(rates)
        require(
            math.isfinite(self.timestamp_jitter_s) and 0 <= self.timestamp_jitter_s < period_s,
            "timestamp_jitter_s",
            self.timestamp_jitter_s,
            f"a standard deviation >= 0 s and < the sample period {period_s:g} s",
        )
        v_max = self.speed.max_mps
        K = self.effects.understeer_K
        require(
            1.0 + K * v_max * v_max > 0,
            "understeer_K",
            K,
            f"1 + K v^2 > 0 at the top speed {v_max:g} m/s (K > {-1.0 / (v_max * v_max):.4g})",
        )
        if self.hitch_model == HitchModel.TRANSIENT:
            require(
                self.rate_hz >= v_max / self.L2,
                "rate_hz",
                self.rate_hz,
                f">= {v_max / self.L2:.4g} Hz, so that the tractor moves at most L2 = "
                f"{self.L2:g} m per step at its top speed {v_max:g} m/s",
            )
        if self.commands.specs:
            min_rate = min(rates)
            require(
                self.commands.duration_s * min_rate >= 1.0,
                "duration_s",
                self.commands.duration_s,
                f">= {1.0 / min_rate:g} s, so that every sensor has two samples",
            )
            check_steady_turn(self.L1, self.L2, self.kappa_peak())

    def curvature_gain(self) -> float:
        """Largest ratio of driven to commanded curvature: 1, or 1/(1 + K v^2) at the top speed
        under oversteer (K < 0)."""
        K = min(self.effects.understeer_K, 0.0)
        v = self.speed.max_mps
        return 1.0 / (1.0 + K * v * v)

    def kappa_peak(self) -> float:
        """Bound on the largest |curvature| (1/m) the run drives: the command's peak times
        :meth:`curvature_gain`."""
        return self.commands.peak_abs() * self.curvature_gain()


@dataclass(frozen=True)
class SimulatedRun:
    """A simulated run: measured frames per sensor group, the truth, parameters and segments.

    ``frames[group]`` has ``t_ns`` (int64, as the sensor stamped it) and the group's signals.
    ``truth`` has ``t_ns`` and kappa_cmd, kappa (actual), v, omega, x, y, yaw, psi at the base
    rate. ``params`` holds the true parameters (L1, L2 and every injected effect). ``seed`` is
    the noise seed.
    """

    frames: Mapping[str, pl.DataFrame]
    truth: pl.DataFrame
    params: Mapping[str, float]
    segments: list[Segment]
    config: TractorTrailerSim
    seed: int = 0


def _first_order_lag(u_half: np.ndarray, dt: float, tau_s: float) -> np.ndarray:
    """Response of tau y' = u - y, starting at rest at ``u[0]``, to ``u`` given on the half-step
    grid (length 2 n - 1): solved exactly for the quadratic through each step's three samples."""
    u0, uh, u1 = u_half[:-2:2], u_half[1:-1:2], u_half[2::2]
    c2 = 2.0 * (u0 - 2.0 * uh + u1) / (dt * dt)
    c1 = (u1 - u0) / dt - c2 * dt

    def particular(s: float) -> np.ndarray:
        return u0 + c1 * (s - tau_s) + c2 * (s * s - 2.0 * tau_s * s + 2.0 * tau_s * tau_s)

    a, a_half = math.exp(-dt / tau_s), math.exp(-dt / (2.0 * tau_s))
    p0 = particular(0.0)
    y0 = float(u_half[0])
    y_next = lfilter([1.0], [1.0, -a], particular(dt) - a * p0, zi=[a * y0])[0]
    y_full = np.concatenate([[y0], y_next])
    out = np.empty_like(u_half)
    out[::2] = y_full
    out[1::2] = particular(dt / 2.0) + a_half * (y_full[:-1] - p0)
    return out


def _psi_rk4(v: np.ndarray, k: np.ndarray, dt: float, L1: float, L2: float) -> np.ndarray:
    """RK4 of d psi/dt = v (k (1 + L1/L2 cos psi) - sin(psi)/L2) from psi = 0.

    ``v`` and ``k`` are given on the half-step grid (length 2 n - 1); returns psi at the n full
    steps (``calib.tractor_trailer.models.hitch_rk4``: the only state-dependent part of the
    dynamics).
    """
    vv, kk = np.asarray(v, dtype=float), np.asarray(k, dtype=float)
    n = (vv.size + 1) // 2
    U = np.stack([vv[0:-2:2] * kk[0:-2:2], vv[1::2] * kk[1::2], vv[2::2] * kk[2::2]], axis=1)
    V = np.stack([vv[0:-2:2], vv[1::2], vv[2::2]], axis=1)
    return rk4_hitch(np.full(n - 1, dt), U, V, 1.0, L1 / L2, 1.0 / L2, 0.0)[:, 0, 0]


def _simpson_steps(f_half: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative integral at the full steps of ``f`` given on the half-step grid (Simpson)."""
    inc = dt / 6.0 * (f_half[:-2:2] + 4.0 * f_half[1:-1:2] + f_half[2::2])
    return np.concatenate([[0.0], np.cumsum(inc)])


def _yaw_half_grid(omega_half: np.ndarray, dt: float) -> np.ndarray:
    """Heading (rad) on the half-step grid from the yaw rate there: Simpson at the full steps,
    the quadratic through each step's three points for the midpoints."""
    yaw = np.empty_like(omega_half)
    yaw[::2] = _simpson_steps(omega_half, dt)
    w0, wh, w1 = omega_half[:-2:2], omega_half[1:-1:2], omega_half[2::2]
    yaw[1::2] = yaw[:-2:2] + dt / 24.0 * (5.0 * w0 + 8.0 * wh - w1)
    return yaw


def _integrate(cfg: TractorTrailerSim, t: np.ndarray) -> dict[str, np.ndarray]:
    """Integrate the kinematics at the base rate (state at t = 0: origin, heading 0, psi = 0).

    Command and speed are evaluated vectorised on the half-step grid; the lag is solved exactly
    for the input's quadratic interpolant, yaw by cumulative Simpson (4th order), x and y by
    Simpson over v cos(yaw), v sin(yaw), and psi by scalar RK4: the accuracy of RK4 on the full
    state.
    """
    eff = cfg.effects
    dt = 1.0 / cfg.rate_hz
    n = t.size
    th = np.arange(2 * n - 1) * (dt / 2.0)
    k_in = cfg.commands(th - eff.actuator_delay_s)
    v = cfg.speed(th)
    k_act = _first_order_lag(k_in, dt, eff.actuator_lag_s) if eff.actuator_lag_s > 0 else k_in
    kappa = k_act / (1.0 + eff.understeer_K * v * v)
    omega = v * kappa
    yaw_h = _yaw_half_grid(omega, dt)
    x = _simpson_steps(v * np.cos(yaw_h), dt)
    y = _simpson_steps(v * np.sin(yaw_h), dt)
    if cfg.hitch_model == HitchModel.STEADY:
        psi = steady_state_psi(kappa[::2], cfg.L1, cfg.L2)
    else:
        psi = _psi_rk4(v, kappa, dt, cfg.L1, cfg.L2)
    return {
        "kappa_cmd": cfg.commands(t),
        "kappa": kappa[::2],
        "v": v[::2],
        "omega": omega[::2],
        "x": x,
        "y": y,
        "yaw": yaw_h[::2],
        "psi": psi,
    }


def simulate_tractor_trailer(cfg: TractorTrailerSim, seed: int = 0) -> SimulatedRun:
    """Simulate ``cfg`` with noise drawn from ``numpy.random.default_rng(seed)``."""
    if not cfg.commands.specs:
        raise ValueError("TractorTrailerSim.commands is empty: give at least one CommandSpec")
    if seed < 0:
        raise SimParameterError("seed", seed, "an integer >= 0")
    rng = np.random.default_rng(seed)
    n = round(cfg.commands.duration_s * cfg.rate_hz) + 1
    t = np.arange(n) / cfg.rate_hz
    truth = _integrate(cfg, t)
    truth["v_cmd"] = cfg.speed(t)
    t_ns = cfg.start_time_ns + np.round(t * 1e9).astype(np.int64)
    eff = cfg.effects
    frames: dict[str, pl.DataFrame] = {}
    for group, signals in SENSOR_GROUPS.items():
        step = max(1, round(cfg.rate_hz / cfg.rates_hz.get(group, cfg.rate_hz)))
        idx = np.arange(0, n, step)
        shift_ns = round(eff.clock_offset_s.get(group, 0.0) * 1e9)
        cols: dict[str, np.ndarray] = {"t_ns": t_ns[idx] + shift_ns}
        for name in signals:
            val = truth[name][idx] * eff.sensor_scale.get(name, 1.0) + eff.sensor_offset.get(
                name, 0.0
            )
            sd = cfg.noise.std.get(name, 0.0)
            cols[name] = val + (rng.normal(0.0, sd, idx.size) if sd > 0 else 0.0)
        frames[group] = pl.DataFrame(cols)
    if cfg.timestamp_jitter_s > 0:
        frames = {g: _jitter(f, cfg, g, rng) for g, f in frames.items()}
    params: dict[str, float] = {"L1": cfg.L1, "L2": cfg.L2}
    if eff.actuator_delay_s:
        params["actuator_delay_s"] = eff.actuator_delay_s
    if eff.actuator_lag_s:
        params["actuator_lag_s"] = eff.actuator_lag_s
    if eff.understeer_K:
        params["understeer_K"] = eff.understeer_K
    params.update({f"sensor_offset.{k}": v for k, v in eff.sensor_offset.items()})
    params.update({f"sensor_scale.{k}": v for k, v in eff.sensor_scale.items()})
    params.update({f"clock_offset_s.{k}": v for k, v in eff.clock_offset_s.items()})
    truth_df = pl.DataFrame({"t_ns": t_ns, **dict(truth.items())})
    return SimulatedRun(frames, truth_df, params, cfg.commands.segments(), cfg, seed)


def _jitter(
    frame: pl.DataFrame, cfg: TractorTrailerSim, group: str, rng: np.random.Generator
) -> pl.DataFrame:
    """``frame`` with Gaussian jitter on ``t_ns`` (clipped so the order is kept)."""
    period_s = 1.0 / cfg.rates_hz.get(group, cfg.rate_hz)
    lim = 0.45 * period_s
    jit = np.clip(rng.normal(0.0, cfg.timestamp_jitter_s, frame.height), -lim, lim)
    return frame.with_columns(pl.col("t_ns") + pl.Series(np.round(jit * 1e9).astype(np.int64)))
