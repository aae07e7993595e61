"""Differential-drive logs (independent of logcal): own wheel kinematics, encoders, motion capture.

Truth: wheel radii r_R, r_L and track b. The motor controller turns the commands (v_cmd,
omega_cmd) into wheel rates with the robot's *nominal* parameters (what its software believes):
phi_R' = (v_cmd + omega_cmd b_n / 2) / r_Rn, phi_L' = (v_cmd - omega_cmd b_n / 2) / r_Ln. The
ground speed of a wheel is u = r phi' (1 - c |r phi'| + g (r phi')^2) (c: ``wheel_slip``, g:
``tyre_growth``, 0 when clean) and

    v = (u_R + u_L) / 2,  omega_w = (u_R - u_L) / b_eff(t),  omega = omega_w (1 - s |omega_w|),
    x' = v cos yaw, y' = v sin yaw, yaw' = omega

(b_eff = b unless ``skid_varying``; s: ``yaw_slip``)
integrated with DOP853 together with the wheel angles (pieces split at the envelope kink and at
a radius change). Sensors: ``/wheels`` (cumulative wheel angles quantised to encoder ticks, with
the encoder kinds applied to the counts), ``/pose`` (motion capture: Gaussian noise, own rate
and phase), ``/cmd/vel``; variant ``gyro``: ``/odom`` (v: wheel odometry with the nominal
parameters, omega: the gyro) and ``/imu/data`` (the same gyro as ``angular_velocity.z``).
"""

from __future__ import annotations

import math
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .robotlog import FloatArray, RobotLog, Stream, grid, quantise, wrap

__all__ = ["PERTURBABLE", "diff_drive_log"]


def _inputs(rng: np.random.Generator, T: float) -> tuple[Any, Any, float]:
    """(v_cmd(t), omega_cmd(t), ramp end): smooth sums of sines after a linear start ramp."""
    vmax = float(rng.uniform(0.15, 0.8))
    wmax = float(rng.uniform(0.3, 1.5))
    n = 3
    fv, fw = rng.uniform(0.02, 0.15, n), rng.uniform(0.03, 0.25, n)
    pv, pw = rng.uniform(0, 2 * np.pi, n), rng.uniform(0, 2 * np.pi, n)
    av = rng.uniform(0.3, 1.0, n)
    aw = rng.uniform(0.3, 1.0, n)
    av, aw = av / av.sum(), aw / aw.sum()
    ramp = 1.5

    def env(t: Any) -> Any:
        return np.clip(np.asarray(t, dtype=float) / ramp, 0.0, 1.0)

    def v_cmd(t: Any) -> Any:
        t = np.asarray(t, dtype=float)
        s = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(av, fv, pv, strict=True))
        return env(t) * vmax * (0.6 + 0.4 * s)

    def w_cmd(t: Any) -> Any:
        t = np.asarray(t, dtype=float)
        s = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(aw, fw, pw, strict=True))
        return env(t) * wmax * s

    return v_cmd, w_cmd, ramp


def _encoder(
    kind: str | None,
    m: float,
    wheel: int,
    k: int,
    phi: FloatArray,
    t: FloatArray,
    t0: float,
    u: FloatArray,
    rate: FloatArray,
    phase: float,
) -> FloatArray:
    """The encoder reading of wheel ``k`` (0 left, 1 right) before quantisation (``rate``: its
    angular rate at ``t``)."""
    if k != wheel:
        return phi
    if kind == "wheel_backlash":
        return np.asarray(phi + 0.5 * m * np.tanh(rate / BACKLASH_RATE), dtype=float)
    if kind == "wheel_eccentricity":
        return np.asarray(phi + m * np.sin(phi + phase), dtype=float)
    if kind == "stuck_encoder" and m > 0:
        lost = np.interp(np.clip(t, t0, t0 + m), t, phi) - np.interp(t0, t, phi)
        return phi - lost
    if kind == "dropped_increments" and m > 0:
        inc = np.diff(phi, prepend=phi[0])
        return phi - np.cumsum(np.where(u < m, inc, 0.0))
    return phi


BACKLASH_RATE = 0.02
"""Wheel rate (rad/s) over which the gear play of ``wheel_backlash`` is taken up."""

PERTURBABLE = ("r_R", "r_L", "b")
"""True parameters ``diff_drive_log(perturb=...)`` shifts (additively); the nominal ones (the
motor controller's) stay, so the wheel rates stay and the motion changes."""


def diff_drive_log(
    seed: int,
    kind: str | None = None,
    magnitude: float = 0.0,
    duration_s: float | None = None,
    variant: str | None = None,
    *,
    perturb: dict[str, float] | None = None,
) -> RobotLog:
    """A differential-drive log with ``kind`` at ``magnitude`` (None / 0: clean). ``variant``:
    ``logcal`` (/wheels, /cmd/vel, /pose) or ``gyro`` (also /odom and /imu/data); None: drawn.
    Every random draw comes from ``seed`` only (not from the kind). ``perturb``: additive
    shifts of the true ``PERTURBABLE`` parameters (the truth reports the shifted values), for
    ``refit.refit_effect``."""
    rng = np.random.default_rng([seed, 0])
    T = duration_s if duration_s is not None else round(float(rng.uniform(20.0, 60.0)), 1)
    r0 = float(rng.uniform(0.03, 0.15))
    r_R, r_L = r0 * (1 + rng.uniform(-0.03, 0.03)), r0 * (1 + rng.uniform(-0.03, 0.03))
    b = float(rng.uniform(0.2, 0.7))
    nom = {"r_R": r0, "r_L": r0, "b": b * (1 + float(rng.uniform(-0.05, 0.05)))}
    dp = dict(perturb or {})
    if set(dp) - set(PERTURBABLE):
        raise ValueError(f"cannot perturb {sorted(set(dp) - set(PERTURBABLE))}")
    r_R, r_L, b = r_R + dp.get("r_R", 0.0), r_L + dp.get("r_L", 0.0), b + dp.get("b", 0.0)
    v_cmd, w_cmd, ramp = _inputs(rng, T)
    ticks = int(rng.choice([512, 1024, 2048, 4096, 8192]))
    wheel_hz = float(rng.uniform(30.0, 100.0))
    pose_hz = float(rng.uniform(30.0, 200.0))
    pos_sd = float(rng.uniform(0.0005, 0.003))
    yaw_sd = float(rng.uniform(0.001, 0.005))
    gyro_sd = float(rng.uniform(0.001, 0.005))
    var = variant or str(rng.choice(["logcal", "gyro"], p=[0.7, 0.3]))

    krng = np.random.default_rng([seed, 99])
    t_change = float(krng.uniform(0.3, 0.7) * T)
    wheel = int(krng.integers(0, 2))
    m = magnitude if kind is not None else 0.0
    c = m if kind == "wheel_slip" else 0.0
    change = kind == "radius_change"
    nrng = np.random.default_rng([seed, 98])  # the added kinds' own draws (older ones unchanged)
    skid_period = float(nrng.uniform(8.0, 25.0))
    ecc_phase = float(nrng.uniform(0.0, 2 * np.pi))
    growth = m if kind == "tyre_growth" else 0.0
    yaw_c = m if kind == "yaw_slip" else 0.0
    skid = m if kind == "skid_varying" else 0.0

    def radii(t: float) -> tuple[float, float]:
        if change and t >= t_change:
            f = 1.0 + m
            return (r_L * f, r_R) if wheel == 0 else (r_L, r_R * f)
        return r_L, r_R

    def rhs(t: float, s: FloatArray) -> list[float]:
        v, w = float(v_cmd(t)), float(w_cmd(t))
        pl, pr = (v - w * nom["b"] / 2) / nom["r_L"], (v + w * nom["b"] / 2) / nom["r_R"]
        rl, rr = radii(t)
        ul = rl * pl * (1 - c * abs(rl * pl) + growth * (rl * pl) ** 2)
        ur = rr * pr * (1 - c * abs(rr * pr) + growth * (rr * pr) ** 2)
        b_eff = b * (1 + skid * 0.5 * (1 - math.cos(2 * math.pi * t / skid_period)))
        vb, wb = 0.5 * (ul + ur), (ur - ul) / b_eff
        wb *= 1 - yaw_c * abs(wb)
        return [vb * math.cos(s[2]), vb * math.sin(s[2]), wb, pl, pr]

    brk = [ramp] + ([t_change] if change else [])
    edges = [0.0, *sorted(x for x in brk if 0 < x < T), T]
    pieces = []
    y0 = [0.0, 0.0, float(rng.uniform(-np.pi, np.pi)), 0.0, 0.0]
    for a, bb in pairwise(edges):
        sol = solve_ivp(
            rhs, (a, bb), y0, method="DOP853", rtol=1e-10, atol=1e-12, dense_output=True
        )
        pieces.append((a, sol.sol))
        y0 = list(sol.y[:, -1])
    starts = np.array([p[0] for p in pieces])

    def state(t: FloatArray) -> FloatArray:
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(pieces) - 1)
        out = np.empty((5, t.size))
        for i in np.unique(idx):
            sel = idx == i
            out[:, sel] = pieces[i][1](t[sel])
        return out

    start_ns = 1_760_000_000_000_000_000
    q = 2 * np.pi / ticks
    streams: dict[str, Stream] = {}

    def stamps(t: FloatArray, g: np.random.Generator, sd: float = 2e-4) -> Any:
        return start_ns + np.round((t + g.normal(0, sd, t.size).clip(-1e-3, 1e-3)) * 1e9).astype(
            np.int64
        )

    g = np.random.default_rng([seed, 1])
    tw = grid(g, wheel_hz, T, jitter=0.02)
    sw = state(tw)
    u = g.random(tw.size)
    t0 = float(krng.uniform(0.1, 0.8) * T)
    rate_l = (v_cmd(tw) - w_cmd(tw) * nom["b"] / 2) / nom["r_L"]
    rate_r = (v_cmd(tw) + w_cmd(tw) * nom["b"] / 2) / nom["r_R"]
    left_e = _encoder(kind, m, wheel, 0, sw[3], tw, t0, u, rate_l, ecc_phase)
    right_e = _encoder(kind, m, wheel, 1, sw[4], tw, t0, u, rate_r, ecc_phase)
    left, right = quantise(left_e, q), quantise(right_e, q)
    qsd = q / math.sqrt(12)
    streams["/wheels"] = Stream(
        "/wheels",
        stamps(tw, g),
        tw,
        {"left": left, "right": right},
        {"left": qsd, "right": qsd},
        expected={"left": left_e, "right": right_e},
    )
    g = np.random.default_rng([seed, 2])
    tp = grid(g, pose_hz, T)
    sp = state(tp)
    n = tp.size
    streams["/pose"] = Stream(
        "/pose",
        stamps(tp, g, 1e-4),
        tp,
        {
            "x": sp[0] + g.normal(0, pos_sd, n),
            "y": sp[1] + g.normal(0, pos_sd, n),
            "yaw": wrap(sp[2] + g.normal(0, yaw_sd, n)),
        },
        {"x": pos_sd, "y": pos_sd, "yaw": yaw_sd},
        angle=("yaw",),
        expected={"x": sp[0], "y": sp[1], "yaw": sp[2]},
    )
    g = np.random.default_rng([seed, 3])
    tc = grid(g, 20.0, T)
    streams["/cmd/vel"] = Stream(
        "/cmd/vel", stamps(tc, g, 0.0), tc, {"v": v_cmd(tc), "omega": w_cmd(tc)}
    )
    if var == "gyro":
        g = np.random.default_rng([seed, 4])
        dt = np.gradient(tw)
        v_odo = 0.5 * (nom["r_R"] * np.gradient(right) + nom["r_L"] * np.gradient(left)) / dt
        h = 1e-4
        yaw_rate = (state(tw + h)[2] - state(np.maximum(tw - h, 0.0))[2]) / (
            tw + h - np.maximum(tw - h, 0.0)
        )
        bias = float(g.normal(0.0, 0.002))
        gyro = yaw_rate + bias + g.normal(0.0, gyro_sd, tw.size)
        st = stamps(tw, g)
        streams["/odom"] = Stream(
            "/odom",
            st,
            tw,
            {"v": v_odo, "omega": gyro},
            {"v": qsd * ticks / (2 * np.pi), "omega": gyro_sd},
        )
        zeros = np.zeros(tw.size)
        streams["/imu/data"] = Stream(
            "/imu/data",
            st,
            tw,
            {"angular_velocity.x": zeros, "angular_velocity.y": zeros, "angular_velocity.z": gyro},
            {"angular_velocity.z": gyro_sd},
        )
    dense = np.linspace(0.0, T, int(T * 50) + 1)
    sd_ = state(dense)
    truth: dict[str, Any] = {
        "robot": "diff_drive",
        "seed": seed,
        "duration_s": T,
        "variant": var,
        "kind": kind,
        "magnitude": m,
        "r_R": r_R,
        "r_L": r_L,
        "b": b,
        "ticks_per_rev": ticks,
        "params": {"r_R": r_R, "r_L": r_L, "b": b},
        "nominal": nom,
        "distance_m": float(np.sum(np.hypot(np.diff(sd_[0]), np.diff(sd_[1])))),
    }
    if kind == "radius_change":
        truth |= {"t_change_s": t_change, "wheel": ("left", "right")[wheel]}
    if kind == "skid_varying":
        truth["skid_period_s"] = skid_period
    if kind in ("stuck_encoder", "dropped_increments", "wheel_backlash", "wheel_eccentricity"):
        truth["wheel"] = ("left", "right")[wheel]
        if kind == "stuck_encoder":
            truth["t_stuck_s"] = [t0, min(T, t0 + m)]
    meta = {
        "logcal": {"robot": "diff_drive"},
        "logcal.nominal": {
            "wheel_radius_right": repr(nom["r_R"]),
            "wheel_radius_left": repr(nom["r_L"]),
            "track_width": repr(nom["b"]),
        },
    }
    csv = {
        ("/wheels", "left", -1): "wheel_left",
        ("/wheels", "right", -1): "wheel_right",
        ("/cmd/vel", "v", -1): "v_cmd",
        ("/cmd/vel", "omega", -1): "omega_cmd",
        ("/pose", "x", -1): "x",
        ("/pose", "y", -1): "y",
        ("/pose", "yaw", -1): "yaw",
    }
    if var == "gyro":
        csv[("/odom", "omega", -1)] = "omega"
    return RobotLog("diff_drive", streams, truth, meta, csv, start_ns=start_ns)
