"""Tractor-trailer logs with catalogue-escaping physics (``kinds.KINDS`` of robot
``tractor_trailer``), as ``RobotLog`` for the robot-independent writers.

The scenario (L1, L2, command and speed profiles, topic rates, dropouts, stalls) is drawn by
``scenario.random_scenario``; the kinematics are integrated here (DOP853, own right-hand side):

    x' = v cos th, y' = v sin th, th' = v kappa,
    psi' = v kappa - (v sin psi - L1 v kappa cos psi) / L2(t) - c v^2 kappa

with kappa = kappa_cmd(t), v = speed(t) (no catalogue effects: no delay, lag, offsets), L2(t)
the trailer (changing at t_swap for ``trailer_swap``) and c the ``trailer_slip``
(``tyre_saturation``: the trailer axle's slip angle alpha, psi' gets -v alpha / L2). Sensor
kinds (backlash, nonlinearity, gain, clock drift, hysteresis, ripple, low-pass) act on the
recorded hitch angle only. Noise is drawn from streams seeded by (seed, topic) that do not
depend on the kind, so the recording without the kind (magnitude 0) shares every random draw.
"""

from __future__ import annotations

import math
from dataclasses import replace
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .generate import _sample
from .robotlog import FloatArray, RobotLog, Stream, grid, quantise, wrap
from .scenario import TOPICS, Scenario, random_scenario

__all__ = ["PERTURBABLE", "backlash", "hysteresis", "lowpass", "tractor_log"]

_STD = {
    "v": 0.02,
    "omega": 0.005,
    "x": 0.02,
    "y": 0.02,
    "yaw": 0.005,
    "angle": 0.005,
    "curvature": 0.0,
}
_DENSE_HZ = 500.0
G = 9.81
"""Gravity (m/s^2): ``tyre_saturation``'s lateral acceleration is counted in g."""
SLIP_MAX = 0.15
"""The largest side-slip angle (rad) of the trailer's tyres under ``tyre_saturation`` (beyond
it the axle slides: the slip angle saturates)."""


def backlash(u: FloatArray, width: float) -> FloatArray:
    """The play operator: y follows u only when |u - y| exceeds width / 2 (y(0) = u(0))."""
    h = 0.5 * width
    y = np.empty_like(u)
    cur = float(u[0])
    for i, x in enumerate(u.tolist()):
        if x > cur + h:
            cur = x - h
        elif x < cur - h:
            cur = x + h
        y[i] = cur
    return y


def _integrate(
    scn: Scenario,
    L2_after: float,
    t_swap: float,
    c: float,
    psi0: float = 0.0,
    tyre: float = 0.0,
) -> tuple[Any, ...]:
    cmd, spd, L1, T = scn.command, scn.speed, scn.L1, scn.duration_s
    brk = set(cmd.breaks()) | set(spd.breaks()) | {t_swap}
    edges = [0.0, *sorted(b for b in brk if 1e-9 < b < T - 1e-9), T]
    y0 = [0.0, 0.0, 0.0, psi0]
    pieces = []
    for a, b in pairwise(edges):
        if b - a < 1e-9:
            continue
        mid = 0.5 * (a + b)
        L2 = scn.L2 if mid < t_swap else L2_after

        def rhs(t: float, s: FloatArray, mid: float = mid, L2: float = L2) -> list[float]:
            v = spd(t)
            k = cmd(t, t > mid)
            w = v * k
            dpsi = w - (v * math.sin(s[3]) - L1 * w * math.cos(s[3])) / L2 - c * v * v * k
            if tyre:
                a_g = v * v * k / G
                dpsi -= v * SLIP_MAX * math.tanh(tyre * a_g * abs(a_g) / SLIP_MAX) / L2
            return [v * math.cos(s[2]), v * math.sin(s[2]), w, dpsi]

        sol = solve_ivp(rhs, (a, b), y0, method="DOP853", rtol=1e-9, atol=1e-11, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"integration failed on [{a}, {b}]: {sol.message}")
        pieces.append((a, sol.sol))
        y0 = list(sol.y[:, -1])
    return tuple(pieces)


def _state(pieces: tuple[Any, ...], t: FloatArray) -> FloatArray:
    starts = np.array([p[0] for p in pieces])
    idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(pieces) - 1)
    out = np.empty((4, t.size))
    for i in np.unique(idx):
        m = idx == i
        out[:, m] = pieces[i][1](t[m])
    return out


def hysteresis(u: FloatArray, h: float, a: float) -> FloatArray:
    """A Duhem hysteresis: z relaxes towards sign(du) over an input travel ``a`` (z' = |u'| / a
    (sign u' - z), exact per step), the output u - h z (z(0) = 0)."""
    du = np.diff(u, prepend=u[0])
    z = np.empty_like(u)
    cur = 0.0
    for i, d in enumerate(du.tolist()):
        if d != 0.0:
            target = 1.0 if d > 0 else -1.0
            cur = target + (cur - target) * math.exp(-abs(d) / a)
        z[i] = cur
    return np.asarray(u - h * z, dtype=float)


def lowpass(u: FloatArray, t: FloatArray, tau: float) -> FloatArray:
    """First-order low-pass of ``u`` sampled at ``t`` (exact for a piecewise-constant input,
    starting at u(0))."""
    y = np.empty_like(u)
    cur = float(u[0])
    alpha = 1.0 - np.exp(-np.diff(t, prepend=t[0]) / tau)
    for i, (x, al) in enumerate(zip(u.tolist(), alpha.tolist(), strict=True)):
        cur += al * (x - cur)
        y[i] = cur
    return y


def _hitch(
    kind: str | None, m: float, psi: FloatArray, t: FloatArray, extra: dict[str, float]
) -> FloatArray:
    if kind == "hitch_backlash" and m > 0:
        return backlash(psi, m)
    if kind == "hitch_hysteresis" and m > 0:
        return hysteresis(psi, m, m * extra["relax_per_h"])
    if kind == "hitch_ripple":
        return np.asarray(
            psi + m * np.sin(extra["ripple_n"] * psi + extra["ripple_phase"]), dtype=float
        )
    if kind == "hitch_lowpass" and m > 0:
        return lowpass(psi, t, m)
    if kind == "hitch_nonlinearity":
        return psi + m * (np.sin(2 * psi) - 2 * psi)
    if kind == "hitch_gain":
        return (1.0 + m) * psi
    return psi


PERTURBABLE = ("L1", "L2", "psi0")
"""Parameters ``tractor_log(perturb=...)`` shifts (additively): the link lengths and the
initial hitch angle (0 unperturbed)."""


def tractor_log(
    seed: int,
    kind: str | None = None,
    magnitude: float = 0.0,
    duration_s: float | None = None,
    *,
    perturb: dict[str, float] | None = None,
) -> RobotLog:
    """A tractor-trailer log (``tractor_trailer`` topics of LOG_FORMAT.md) with ``kind`` at
    ``magnitude`` (None or magnitude 0: clean). Draws from ``seed`` only (not from the kind).
    ``perturb``: additive shifts of ``PERTURBABLE`` parameters (the same draws otherwise; the
    truth reports the shifted values), for ``refit.refit_effect``."""
    rng = np.random.default_rng([seed, 0])
    T = duration_s if duration_s is not None else round(float(rng.uniform(30.0, 60.0)), 1)
    scn = random_scenario(rng, duration_s=T)
    dp = dict(perturb or {})
    if set(dp) - set(PERTURBABLE):
        raise ValueError(f"cannot perturb {sorted(set(dp) - set(PERTURBABLE))}")
    if dp.get("L1") or dp.get("L2"):
        scn = replace(scn, L1=scn.L1 + dp.get("L1", 0.0), L2=scn.L2 + dp.get("L2", 0.0))
    krng = np.random.default_rng([seed, 99])
    t_swap = float(krng.uniform(0.3, 0.7) * T)
    noise_scale = float(krng.choice([0.3, 1.0, 3.0]))
    m = magnitude if kind is not None else 0.0
    L2_after = scn.L2 * (1.0 + m) if kind == "trailer_swap" else scn.L2
    c = m if kind == "trailer_slip" else 0.0
    nrng = np.random.default_rng([seed, 98])  # the added kinds' own draws (older ones unchanged)
    extra = {
        "relax_per_h": float(nrng.uniform(2.5, 5.0)),
        "ripple_n": float(nrng.integers(4, 13)),
        "ripple_phase": float(nrng.uniform(0.0, 2 * np.pi)),
    }
    pieces = _integrate(
        scn,
        L2_after,
        t_swap if kind == "trailer_swap" else T + 1.0,
        c,
        dp.get("psi0", 0.0),
        m if kind == "tyre_saturation" else 0.0,
    )
    dense_t = grid(np.random.default_rng(0), _DENSE_HZ, T)
    dense_psi = _state(pieces, dense_t)[3]
    rec_psi = _hitch(kind, m, dense_psi, dense_t, extra)

    srng = np.random.default_rng([seed, 1])
    stalls: list[tuple[float, float]] = []
    for _ in range(scn.n_stalls):
        ln = float(srng.uniform(min(0.2, scn.max_stall_s), scn.max_stall_s))
        s = float(srng.uniform(0.05 * T, max(0.05 * T, 0.95 * T - ln)))
        stalls.append((s, s + ln))
    start_ns = scn.start_ns
    streams: dict[str, Stream] = {}
    for k, (group, spec) in enumerate(sorted(scn.topics.items())):
        tdef = TOPICS["tractor_trailer"][group]
        grng = np.random.default_rng([seed, 10 + k])
        _, t, stamp_err = _sample(spec, T, grng, stalls)
        st = _state(pieces, t)
        v_cmd = scn.speed.values(t)
        kc = scn.command.values(t)
        true = {
            "kappa_cmd": kc,
            "v_cmd": v_cmd,
            "omega_cmd": v_cmd * kc,
            "v": v_cmd,
            "omega": v_cmd * kc,
            "x": st[0],
            "y": st[1],
            "yaw": st[2],
            "psi": np.interp(t, dense_t, rec_psi),
        }
        fields: dict[str, FloatArray] = {}
        noise: dict[str, float] = {}
        expected: dict[str, FloatArray] = {}
        for f, sig in zip(tdef.fields, tdef.signals, strict=True):
            expected[f] = np.asarray(true[sig], dtype=float)
            sd = 0.0 if group.startswith("cmd") else noise_scale * _STD[f]
            q = float(spec.quantum.get(f, 0.0))
            val = true[sig] + grng.normal(0.0, 1.0, t.size) * sd
            val = quantise(val, q)
            fields[f] = wrap(val) if f == "yaw" else val
            noise[f] = math.sqrt(sd * sd + q * q / 12.0)
        stamp_s = t + stamp_err
        if kind == "clock_drift" and group == "hitch":
            stamp_s = stamp_s * (1.0 + m)
        stamps = start_ns + np.round(stamp_s * 1e9).astype(np.int64)
        streams[tdef.topic] = Stream(
            tdef.topic,
            stamps,
            t,
            fields,
            noise,
            angle=("yaw",) if "yaw" in fields else (),
            expected=expected,
        )
    truth: dict[str, Any] = {
        "robot": "tractor_trailer",
        "seed": seed,
        "duration_s": T,
        "L1": scn.L1,
        "L2": scn.L2,
        "kind": kind,
        "magnitude": m,
        "max_abs_psi": float(np.max(np.abs(dense_psi))),
        "params": {"L1": scn.L1, "L2": scn.L2},
    }
    if kind == "trailer_swap":
        truth |= {"t_swap_s": t_swap, "L2_after": L2_after}
    if kind == "hitch_backlash":
        truth["hitch_dead_band_rad"] = m
    if kind == "hitch_hysteresis":
        truth["hysteresis_relax_rad"] = m * extra["relax_per_h"]
    if kind == "hitch_ripple":
        truth |= {"ripple_n": int(extra["ripple_n"]), "ripple_phase": extra["ripple_phase"]}
    csv = {
        ("/cmd/curvature", "curvature", -1): "kappa_cmd",
        ("/cmd/vel", "v", -1): "v_cmd",
        ("/odom", "v", -1): "v",
        ("/odom", "omega", -1): "omega",
        ("/pose", "x", -1): "x",
        ("/pose", "y", -1): "y",
        ("/pose", "yaw", -1): "yaw",
        ("/hitch/angle", "angle", -1): "psi",
    }
    meta = {"logcal": {"robot": "tractor_trailer"}}
    return RobotLog("tractor_trailer", streams, truth, meta, csv, start_ns=start_ns)
