"""Kinematics of the tractor + off-axle trailer, integrated with scipy's DOP853.

State s = (x, y, th1, psi, kl): C1 position, tractor heading, hitch angle psi = th1 - th2 and
the lagged curvature kl (a state only with an actuator lag; constant otherwise).

    kc(t)  = u(t - d)                       (d: actuator delay; u = curvature command), or
             tan(u(t - d)) / wheelbase      (u = steering angle, for a steered robot)
    kl'    = (kc(t) - kl) / tau             (tau: actuator lag; without lag kl = kc(t))
    kappa  = kl / (1 + K v^2)               (K: understeer)
    v      = drive_gain * speed(t)
    x' = v cos th1, y' = v sin th1, th1' = v kappa,
    psi'   = v kappa - (v sin psi - L1 v kappa cos psi) / L2 - c v^2 kappa   (c: trailer slip)

Pieces between input discontinuities (steps of the command shifted by d, kinks of the speed
envelope) are integrated separately; inside a piece the inputs take their one-sided limits, so
the right-hand side is smooth there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .inputs import FloatArray
from .scenario import Scenario

__all__ = ["Trajectory", "integrate"]


@dataclass(frozen=True)
class Trajectory:
    """The true continuous run: dense ODE solutions per piece, evaluable at any time."""

    scenario: Scenario
    starts: FloatArray
    sols: tuple[Any, ...]
    n_rhs: int

    def state(self, t: FloatArray) -> FloatArray:
        """State (5, n) = (x, y, th1, psi, kl) at times ``t`` (s), clipped to [0, duration]."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.scenario.duration_s)
        out = np.empty((5, t.size))
        piece = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.sols) - 1)
        for i in np.unique(piece):
            m = piece == i
            out[:, m] = self.sols[i](t[m])
        return out

    def kappa_cmd(self, t: FloatArray, delayed: bool = False) -> FloatArray:
        """Commanded curvature (1/m) at ``t``; ``delayed``: as felt, kc(t) = cmd(t - d)."""
        scn = self.scenario
        d = scn.effects.actuator_delay_s if delayed else 0.0
        u = scn.command.values(np.asarray(t, dtype=float) - d)
        return np.tan(u) / scn.wheelbase if scn.wheelbase else u

    def signals(self, t: FloatArray) -> dict[str, FloatArray]:
        """True signals at ``t`` (s), error-free.

        ``x, y, yaw`` (C1, yaw unwrapped), ``psi``, ``kappa`` (actual), ``v`` (actual),
        ``omega`` = v kappa, ``kappa_cmd`` (undelayed), ``v_cmd`` (commanded speed),
        ``omega_cmd`` = v_cmd kappa_cmd, ``delta_cmd``/``delta`` (steering angles, steered
        robots: delta = atan(wheelbase kappa_lagged)), ``th2`` (trailer heading), ``xP, yP``
        (hitch), ``x2, y2, yaw2`` (trailer axle C2).
        """
        scn, eff = self.scenario, self.scenario.effects
        t = np.asarray(t, dtype=float)
        s = self.state(t)
        v_cmd = scn.speed.values(t)
        v = scn.drive_gain * v_cmd
        kl = s[4] if eff.actuator_lag_s > 0 else self.kappa_cmd(t, delayed=True)
        kappa = kl / (1.0 + eff.understeer_K * v * v)
        th1, psi = s[2], s[3]
        th2 = th1 - psi
        xP = s[0] - scn.L1 * np.cos(th1)
        yP = s[1] - scn.L1 * np.sin(th1)
        x2 = xP - scn.L2 * np.cos(th2)
        y2 = yP - scn.L2 * np.sin(th2)
        kc = self.kappa_cmd(t)
        out = {
            "x": s[0],
            "y": s[1],
            "yaw": th1,
            "psi": psi,
            "kappa": kappa,
            "v": v,
            "omega": v * kappa,
            "kappa_cmd": kc,
            "v_cmd": v_cmd,
            "omega_cmd": v_cmd * kc,
            "th2": th2,
            "xP": xP,
            "yP": yP,
            "x2": x2,
            "y2": y2,
            "yaw2": th2,
        }
        if scn.wheelbase:
            out["delta_cmd"] = scn.command.values(t)
            out["delta"] = np.arctan(scn.wheelbase * kl)
        return out


def integrate(scn: Scenario, rtol: float = 1e-10, atol: float = 1e-12) -> Trajectory:
    """Integrate ``scn`` over [0, duration_s] (C1 starts at the origin, heading yaw0, psi0)."""
    eff = scn.effects
    cmd, spd = scn.command, scn.speed
    d, tau, K, cs = eff.actuator_delay_s, eff.actuator_lag_s, eff.understeer_K, eff.trailer_slip
    L1, L2, gain, wb = scn.L1, scn.L2, scn.drive_gain, scn.wheelbase
    T = scn.duration_s
    cos, sin, tan = math.cos, math.sin, math.tan

    def kc(t: float, left: bool) -> float:
        u = cmd(t - d, left)
        return tan(u) / wb if wb else u

    brk = {b + d for b in cmd.breaks()} | set(spd.breaks())
    edges = [0.0, *sorted(b for b in brk if 1e-9 < b < T - 1e-9), T]
    y0 = [0.0, 0.0, scn.yaw0, scn.psi0, kc(0.0, False)]
    sols: list[Any] = []
    starts: list[float] = []
    n_rhs = 0
    for a, b in pairwise(edges):
        if b - a < 1e-9:
            continue
        mid = 0.5 * (a + b)

        def rhs(t: float, s: FloatArray, mid: float = mid) -> list[float]:
            left = t > mid
            v = gain * spd(t)
            if tau > 0:
                kl = s[4]
                dkl = (kc(t, left) - kl) / tau
            else:
                kl = kc(t, left)
                dkl = 0.0
            k = kl / (1.0 + K * v * v)
            th, p = s[2], s[3]
            w = v * k
            dpsi = w - (v * sin(p) - L1 * w * cos(p)) / L2 - cs * v * v * k
            return [v * cos(th), v * sin(th), w, dpsi, dkl]

        sol = solve_ivp(rhs, (a, b), y0, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"integration failed on [{a}, {b}]: {sol.message}")
        n_rhs += int(sol.nfev)
        sols.append(sol.sol)
        starts.append(a)
        y0 = list(sol.y[:, -1])
        if tau <= 0:
            y0[4] = kc(b, False)
    return Trajectory(scn, np.asarray(starts), tuple(sols), n_rhs)
