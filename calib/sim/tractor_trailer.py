"""Simulator of the tractor + off-axle trailer driven by curvature commands.

Physics: the commanded curvature passes through the actuator (optional dead time, first-order
lag, understeer), C1 moves at speed v along that curvature, and the joint angle follows the
transient off-axle kinematics d psi/dt = v kappa - (v sin psi - L1 v kappa cos psi)/L2
(or, with ``hitch_model="steady"``, the patent's steady-state relation). Sensors sample the
truth per group at their own rates, with Gaussian noise, optional bias/scale and clock offsets.

Sensor groups and the logical signals they carry (see LOG_FORMAT.md):
``cmd`` (kappa_cmd, v_cmd), ``odom`` (v, omega), ``pose`` (x, y, yaw), ``hitch`` (psi).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import polars as pl

from calib.models.tractor_trailer import psi_rate, steady_state_psi
from calib.results import Segment
from calib.sim.commands import CommandSequence

__all__ = [
    "SENSOR_GROUPS",
    "Effects",
    "NoiseSpec",
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


@dataclass(frozen=True)
class TractorTrailerSim:
    """Configuration of one simulated run.

    Args:
        L1, L2: link lengths (m).
        commands: curvature command sequence.
        speed: speed profile.
        noise: sensor noise.
        effects: injected effects.
        hitch_model: "transient" (real kinematics) or "steady" (psi on the steady-state curve).
        rate_hz: integration and base sampling rate (Hz).
        rates_hz: per sensor group sampling rate (Hz); must divide ``rate_hz``.
        start_time_ns: absolute time of t = 0 (ns since the Unix epoch).
    """

    L1: float = 1.25
    L2: float = 2.48
    commands: CommandSequence = field(default_factory=lambda: CommandSequence([]))
    speed: SpeedProfile = field(default_factory=SpeedProfile)
    noise: NoiseSpec = field(default_factory=NoiseSpec)
    effects: Effects = field(default_factory=Effects)
    hitch_model: Literal["transient", "steady"] = "transient"
    rate_hz: float = 100.0
    rates_hz: Mapping[str, float] = field(
        default_factory=lambda: {"cmd": 100.0, "odom": 100.0, "pose": 50.0, "hitch": 100.0}
    )
    start_time_ns: int = 1_750_000_000_000_000_000


@dataclass(frozen=True)
class SimulatedRun:
    """A simulated run: measured frames per sensor group, the truth, parameters and segments.

    ``frames[group]`` has ``t_ns`` (int64, as the sensor stamped it) and the group's signals.
    ``truth`` has ``t_ns`` and kappa_cmd, kappa (actual), v, omega, x, y, yaw, psi at the base
    rate. ``params`` holds the true parameters (L1, L2 and every injected effect).
    """

    frames: Mapping[str, pl.DataFrame]
    truth: pl.DataFrame
    params: Mapping[str, float]
    segments: list[Segment]
    config: TractorTrailerSim


def _actual_kappa_cmd(cfg: TractorTrailerSim, t: np.ndarray) -> np.ndarray:
    """Command as the actuator sees it after the dead time (1/m)."""
    return cfg.commands(t - cfg.effects.actuator_delay_s)


def _integrate(cfg: TractorTrailerSim, t: np.ndarray) -> dict[str, np.ndarray]:
    """RK4 on the state [x, y, yaw, psi, kappa_lagged] at the base rate."""
    eff = cfg.effects
    tau = eff.actuator_lag_s
    dt = 1.0 / cfg.rate_hz

    def kappa_of(t_s: float, k_lag: float) -> tuple[float, float]:
        k_in = float(_actual_kappa_cmd(cfg, np.array([t_s]))[0])
        v = float(cfg.speed(np.array([t_s]))[0])
        k_act = k_lag if tau > 0 else k_in
        return k_act / (1.0 + eff.understeer_K * v * v), v

    def rhs(t_s: float, s: np.ndarray) -> np.ndarray:
        k, v = kappa_of(t_s, s[4])
        k_in = float(_actual_kappa_cmd(cfg, np.array([t_s]))[0])
        dk = (k_in - s[4]) / tau if tau > 0 else 0.0
        dpsi = 0.0 if cfg.hitch_model == "steady" else float(psi_rate(v, k, s[3], cfg.L1, cfg.L2))
        return np.array([v * np.cos(s[2]), v * np.sin(s[2]), v * k, dpsi, dk])

    n = t.size
    out = np.zeros((n, 5))
    s = np.zeros(5)
    s[4] = float(_actual_kappa_cmd(cfg, t[:1])[0])
    for i in range(n):
        out[i] = s
        if i == n - 1:
            break
        ti = t[i]
        k1 = rhs(ti, s)
        k2 = rhs(ti + dt / 2, s + dt / 2 * k1)
        k3 = rhs(ti + dt / 2, s + dt / 2 * k2)
        k4 = rhs(ti + dt, s + dt * k3)
        s = s + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    kappa = np.empty(n)
    v = cfg.speed(t)
    for i in range(n):
        kappa[i] = kappa_of(t[i], out[i, 4])[0]
    psi = steady_state_psi(kappa, cfg.L1, cfg.L2) if cfg.hitch_model == "steady" else out[:, 3]
    return {
        "kappa_cmd": cfg.commands(t),
        "kappa": kappa,
        "v": v,
        "omega": v * kappa,
        "x": out[:, 0],
        "y": out[:, 1],
        "yaw": out[:, 2],
        "psi": psi,
    }


def simulate_tractor_trailer(cfg: TractorTrailerSim, seed: int = 0) -> SimulatedRun:
    """Simulate ``cfg`` with noise drawn from ``numpy.random.default_rng(seed)``."""
    if not cfg.commands.specs:
        raise ValueError("TractorTrailerSim.commands is empty: give at least one CommandSpec")
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
    return SimulatedRun(frames, truth_df, params, cfg.commands.segments(), cfg)
