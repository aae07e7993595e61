"""Simulate a differential drive from wheel-rate commands: true motion with wheel-radius and
track errors, wheel slip and a skid-steer effective track; encoder quantisation and
ground-truth (motion capture) noise on what is logged. Returns arrays; writers live in
``logtools.writers.diff_drive``.

Motion between samples is an exact arc (wheel rates held constant over each interval, as a
motor controller does), integrated at ``substeps`` per logging interval.

:func:`simulate_odom_imu` simulates the other usual log, wheel odometry and a gyro (no encoder
angles, no ground truth), of a skid steer whose effective track is the geometric one times a
gain that may grow with turn rate, speed, or jointly with both (the ICR model of
:mod:`calib.diff_drive.odom_imu.effects`: switch ``icr_turn``, ``icr_joint``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.dead_reckoning import arc_steps
from calib.diff_drive.kinematics import DiffDriveParams, inverse

__all__ = [
    "DiffDriveSim",
    "OdomImuSim",
    "OdomImuSimConfig",
    "SimConfig",
    "WheelCommands",
    "mixed_commands",
    "simulate_diff_drive",
    "simulate_odom_imu",
    "square_commands",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class WheelCommands:
    """Wheel-rate commands (rad/s) on a uniform time grid ``t`` (s), with the body velocity
    command (m/s, rad/s) they were computed from under the nominal parameters."""

    t: Array
    w_right: Array
    w_left: Array
    v_cmd: Array
    omega_cmd: Array


@dataclass(frozen=True)
class SimConfig:
    """What the simulated robot really is and how it is measured.

    Attributes:
        true: the real wheel radii and geometric track (m).
        nominal: what the robot's software believes (commands use it; logged as nominal).
        track_factor: effective / geometric track (skid steer: > 1; 1 for two driven wheels).
        slip_std: relative std of each wheel's ground speed per logging interval (white).
        slip_per_speed: systematic longitudinal slip growing with speed: each wheel's ground
            travel is its rolling travel times (1 - slip_per_speed * |wheel ground speed|),
            slip_per_speed in 1 / (m/s). (A constant slip fraction is not offered: it is
            exactly a smaller wheel radius, and calibrates as one.)
        counts_per_rev: encoder counts per wheel revolution (0: no quantisation).
        pose_noise: std of the ground-truth pose noise (m, m, rad).
        gyro_noise: std of the logged yaw rate (rad/s).
        substeps: integration steps per logging interval.
    """

    true: DiffDriveParams
    nominal: DiffDriveParams
    track_factor: float = 1.0
    slip_std: float = 0.0
    slip_per_speed: float = 0.0
    counts_per_rev: int = 0
    pose_noise: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyro_noise: float = 0.0
    substeps: int = 4

    @property
    def effective(self) -> DiffDriveParams:
        """The parameters the motion obeys: true radii, effective track."""
        return DiffDriveParams(self.true.r_R, self.true.r_L, self.true.b * self.track_factor)


@dataclass(frozen=True)
class DiffDriveSim:
    """A simulated run: logged arrays (wheels quantised, pose and gyro noisy), the true pose,
    the commands, the configuration and seed."""

    t: Array
    wheel_right: Array
    wheel_left: Array
    x: Array
    y: Array
    yaw: Array
    omega_gyro: Array
    x_true: Array
    y_true: Array
    yaw_true: Array
    commands: WheelCommands
    config: SimConfig
    seed: int
    meta: dict[str, str] = field(default_factory=dict)

    def truth(self) -> dict[str, float]:
        """The true parameters by the names the analysis reports (effective track)."""
        eff = self.config.effective
        return {
            "wheel_radius_right": eff.r_R,
            "wheel_radius_left": eff.r_L,
            "track_width": eff.b,
            "track_width_geometric": self.config.true.b,
        }


def _ramp(t: Array, t0: float, t1: float, ramp: float) -> Array:
    """1 inside [t0, t1], linear ramps of ``ramp`` s at both ends, 0 outside."""
    up = np.clip((t - t0) / ramp, 0, 1) if ramp > 0 else (t >= t0).astype(float)
    down = np.clip((t1 - t) / ramp, 0, 1) if ramp > 0 else (t <= t1).astype(float)
    return np.minimum(up, down)


def square_commands(
    nominal: DiffDriveParams,
    side: float,
    direction: int,
    *,
    v: float = 0.2,
    omega: float = 0.6,
    ramp_s: float = 0.5,
    pause_s: float = 0.5,
    rate_hz: float = 20.0,
) -> WheelCommands:
    """A UMBmark square of side ``side`` (m), ``direction`` +1 counter-clockwise / -1
    clockwise, as open-loop wheel-rate commands: straight sides at ``v`` (m/s) and turns on the
    spot at ``omega`` (rad/s), with ``ramp_s`` acceleration ramps, computed so that the nominal
    odometry sees a closed square."""
    dt = 1.0 / rate_hz
    pieces_v: list[Array] = []
    pieces_w: list[Array] = []
    for _ in range(4):
        for length, speed, is_turn in ((side, v, False), (np.pi / 2, omega, True)):
            dur = length / speed + ramp_s  # trapezoid: area = speed * (dur - ramp)
            tt = np.arange(0.0, dur + pause_s, dt)
            prof = speed * _ramp(tt, 0.0, dur, ramp_s)
            # rescale so the integral is exact on the grid
            area = np.sum(prof) * dt
            prof *= length / area if area > 0 else 0.0
            pieces_v.append(np.zeros_like(prof) if is_turn else prof)
            pieces_w.append(direction * prof if is_turn else np.zeros_like(prof))
    vv = np.concatenate(pieces_v)
    ww = np.concatenate(pieces_w)
    t = np.arange(vv.size, dtype=float) * dt
    wr, wl = inverse(nominal, vv, ww)
    return WheelCommands(t, wr, wl, vv, ww)


def mixed_commands(
    nominal: DiffDriveParams,
    duration_s: float,
    rng: np.random.Generator,
    *,
    v_max: float = 0.4,
    omega_max: float = 1.2,
    hold_s: tuple[float, float] = (1.0, 4.0),
    rate_hz: float = 20.0,
) -> WheelCommands:
    """Random driving: piecewise-linear (v, omega) commands between random set points held for
    ``hold_s`` seconds (straights, arcs both ways, turns on the spot), as wheel-rate commands."""
    dt = 1.0 / rate_hz
    t = np.arange(0.0, duration_s, dt)
    knots_t = [0.0]
    while knots_t[-1] < duration_s:
        knots_t.append(knots_t[-1] + rng.uniform(*hold_s))
    kt = np.array(knots_t)
    kind = rng.integers(0, 4, size=kt.size)  # 0 straight, 1 arc, 2 spin, 3 arc
    kv = np.where(kind == 2, 0.0, rng.uniform(0.3, 1.0, kt.size) * v_max)
    kw = np.where(kind == 0, 0.0, rng.uniform(-1.0, 1.0, kt.size) * omega_max)
    kv[0] = kw[0] = 0.0
    vv = np.interp(t, kt, kv)
    ww = np.interp(t, kt, kw)
    wr, wl = inverse(nominal, vv, ww)
    return WheelCommands(t, wr, wl, vv, ww)


def simulate_diff_drive(
    commands: WheelCommands,
    config: SimConfig,
    seed: int = 0,
    pose0: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> DiffDriveSim:
    """Drive ``commands`` with the robot of ``config``; log at the commands' time grid."""
    rng = np.random.default_rng(seed)
    t = commands.t
    dt = np.diff(t)
    # wheel angle increments per interval (commands held over the interval)
    d_r = commands.w_right[:-1] * dt
    d_l = commands.w_left[:-1] * dt
    # slip: the ground sees a perturbed wheel turn; the encoder sees the commanded one
    slip_r = 1.0 + config.slip_std * rng.standard_normal(d_r.size)
    slip_l = 1.0 + config.slip_std * rng.standard_normal(d_l.size)
    if config.slip_per_speed:
        k_s, eff0 = config.slip_per_speed, config.effective
        slip_r *= 1.0 - k_s * np.abs(eff0.r_R * commands.w_right[:-1])
        slip_l *= 1.0 - k_s * np.abs(eff0.r_L * commands.w_left[:-1])
    k = max(1, int(config.substeps))
    g_r = np.repeat(d_r * slip_r / k, k)
    g_l = np.repeat(d_l * slip_l / k, k)
    dx, dy, yaw_sub = arc_steps(g_r, g_l, config.effective, pose0[2])
    x_true = pose0[0] + np.concatenate([[0.0], np.cumsum(dx)[k - 1 :: k]])
    y_true = pose0[1] + np.concatenate([[0.0], np.cumsum(dy)[k - 1 :: k]])
    yaw_true = np.concatenate([[pose0[2]], yaw_sub[k - 1 :: k]])
    phi_r = np.concatenate([[0.0], np.cumsum(d_r)])
    phi_l = np.concatenate([[0.0], np.cumsum(d_l)])
    if config.counts_per_rev > 0:
        q = 2 * np.pi / config.counts_per_rev
        phi_r = np.floor(phi_r / q) * q
        phi_l = np.floor(phi_l / q) * q
    sx, sy, sth = config.pose_noise
    n = t.size
    eff = config.effective
    rate_true = np.gradient(yaw_true, t) if n > 1 else np.zeros(n)
    return DiffDriveSim(
        t=t.copy(),
        wheel_right=phi_r,
        wheel_left=phi_l,
        x=x_true + sx * rng.standard_normal(n),
        y=y_true + sy * rng.standard_normal(n),
        yaw=yaw_true + sth * rng.standard_normal(n),
        omega_gyro=rate_true + config.gyro_noise * rng.standard_normal(n),
        x_true=x_true,
        y_true=y_true,
        yaw_true=yaw_true,
        commands=commands,
        config=config,
        seed=seed,
        meta={"effective_track": repr(eff.b)},
    )


@dataclass(frozen=True)
class OdomImuSimConfig:
    """A skid steer logged by its wheel odometry and a gyro.

    The odometry reports the speed v and turn rate omega_odo the wheels give with the
    geometric track; the robot turns at omega_odo (1 - icr_turn |omega_odo| - icr_joint |v|
    |omega_odo|) / G with G = gain (1 + turn_slip |omega_odo| + speed_slip |v|): ``gain`` the
    effective / geometric track of a slow turn, ``turn_slip`` (s/rad) and ``speed_slip`` (s/m)
    the single-covariate growths, ``icr_turn`` (s/rad) and ``icr_joint`` (s^2/(m rad)) the ICR
    model's share of the turn lost (treads' centres of rotation moving outwards with turn rate
    and centripetal acceleration). The gyro reads the true rate plus
    ``gyro_bias`` and white noise; commands are piecewise linear between random knots every
    ``knot_s`` (|omega_odo| up to ``max_turn``, v from 0 to ``max_speed``)."""

    duration_s: float = 120.0
    rate_hz: float = 50.0
    gain: float = 1.0
    turn_slip: float = 0.0
    speed_slip: float = 0.0
    icr_turn: float = 0.0
    icr_joint: float = 0.0
    gyro_bias: float = 0.01
    gyro_noise: float = 0.02
    odom_noise: float = 0.003
    max_turn: float = 1.2
    max_speed: float = 1.0
    knot_s: float = 3.0


@dataclass(frozen=True)
class OdomImuSim:
    """A simulated odometry + gyro log: time (s), the odometry's speed (m/s) and yaw rate
    (rad/s), the gyro's yaw rate, the true yaw rate and gain per sample."""

    t: Array
    odom_v: Array
    odom_omega: Array
    gyro_z: Array
    omega_true: Array
    gain: Array
    config: OdomImuSimConfig
    seed: int


def simulate_odom_imu(config: OdomImuSimConfig, seed: int = 0) -> OdomImuSim:
    """One log of :class:`OdomImuSimConfig`."""
    rng = np.random.default_rng(seed)
    c = config
    t = np.arange(0.0, c.duration_s, 1.0 / c.rate_hz)
    knots = np.arange(0.0, c.duration_s + c.knot_s, c.knot_s)
    w_odo = np.interp(t, knots, rng.uniform(-c.max_turn, c.max_turn, knots.size))
    v = np.interp(t, knots, rng.uniform(0.0, c.max_speed, knots.size))
    rate, speed = np.abs(w_odo), np.abs(v)
    kept = 1 - c.icr_turn * rate - c.icr_joint * speed * rate
    g = c.gain * (1 + c.turn_slip * rate + c.speed_slip * speed) / kept
    w_true = w_odo / g
    return OdomImuSim(
        t,
        v,
        w_odo + c.odom_noise * rng.standard_normal(t.size),
        w_true + c.gyro_bias + c.gyro_noise * rng.standard_normal(t.size),
        w_true,
        g,
        config,
        seed,
    )
