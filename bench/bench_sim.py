"""Simulator speed and accuracy, against a baseline measured in the same run.

Baseline: the original full-state RK4 with a per-step Python call of the command and speed
profiles (the simulator before it was vectorised). Prints times, the speed-up ratio, the time of
a 1-hour 100 Hz run (new scheme only) and the deviation from a DOP853 solve (rtol 1e-11).

    python bench/bench_sim.py [--hours H]
"""

from __future__ import annotations

import argparse
import itertools
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from calib.tractor_trailer.models.hitch_kinematics import psi_rate
from calib.tractor_trailer.sim.presets import patent_mixed
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    NoiseSpec,
    TractorTrailerSim,
    simulate_tractor_trailer,
)


def baseline_rk4(cfg: TractorTrailerSim, t: np.ndarray) -> np.ndarray:
    """The original scheme: RK4 on [x, y, yaw, psi, kappa_lag], profiles called per stage."""
    eff, tau, dt = cfg.effects, cfg.effects.actuator_lag_s, 1.0 / cfg.rate_hz

    def rhs(ts: float, s: np.ndarray) -> np.ndarray:
        k_in = float(cfg.commands(np.array([ts - eff.actuator_delay_s]))[0])
        v = float(cfg.speed(np.array([ts]))[0])
        k = (s[4] if tau > 0 else k_in) / (1.0 + eff.understeer_K * v * v)
        dk = (k_in - s[4]) / tau if tau > 0 else 0.0
        dpsi = float(psi_rate(v, k, s[3], cfg.L1, cfg.L2))
        return np.array([v * np.cos(s[2]), v * np.sin(s[2]), v * k, dpsi, dk])

    out = np.zeros((t.size, 5))
    s = np.zeros(5)
    s[4] = float(cfg.commands(np.array([-eff.actuator_delay_s]))[0])
    for i in range(t.size - 1):
        out[i] = s
        k1 = rhs(t[i], s)
        k2 = rhs(t[i] + dt / 2, s + dt / 2 * k1)
        k3 = rhs(t[i] + dt / 2, s + dt / 2 * k2)
        k4 = rhs(t[i] + dt, s + dt * k3)
        s = s + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    out[-1] = s
    return out


def reference(cfg: TractorTrailerSim, t: np.ndarray) -> np.ndarray:
    """Full state by solve_ivp DOP853 (rtol 1e-11), segment by segment (kinks at boundaries)."""
    eff, tau = cfg.effects, cfg.effects.actuator_lag_s

    def rhs(ts: float, s: np.ndarray) -> list[float]:
        k_in = float(cfg.commands(ts - eff.actuator_delay_s)[0])
        v = float(cfg.speed(np.array([ts]))[0])
        k = (s[4] if tau > 0 else k_in) / (1.0 + eff.understeer_K * v * v)
        dk = (k_in - s[4]) / tau if tau > 0 else 0.0
        return [
            v * np.cos(s[2]),
            v * np.sin(s[2]),
            v * k,
            float(psi_rate(v, k, s[3], cfg.L1, cfg.L2)),
            dk,
        ]

    edges = np.unique(
        np.concatenate([cfg.commands.boundaries_s() + eff.actuator_delay_s, [cfg.speed.ramp_s]])
    )
    edges = edges[(edges > t[0]) & (edges < t[-1])]
    knots = np.concatenate([[t[0]], edges, [t[-1]]])
    s0 = [0.0, 0.0, 0.0, 0.0, float(cfg.commands(-eff.actuator_delay_s)[0])]
    out = np.zeros((t.size, 5))
    for a, b in itertools.pairwise(knots):
        sel = (t >= a) & (t <= b)
        sol = solve_ivp(
            rhs,
            (a, b),
            s0,
            method="DOP853",
            t_eval=t[sel],
            rtol=1e-11,
            atol=1e-12,
            dense_output=True,
        )
        out[sel] = sol.y.T
        s0 = list(sol.sol(b))
    return out


def _time(fn: Callable[..., Any], *args: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    res = fn(*args)
    return res, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0, help="length of the long run (h)")
    args = ap.parse_args()
    eff = Effects(actuator_delay_s=0.2, actuator_lag_s=0.3, understeer_K=0.02)
    cfg = patent_mixed(rate_hz=100.0, noise_scale=0.0, effects=eff)
    cfg = TractorTrailerSim(**{**cfg.__dict__, "noise": NoiseSpec.none()})
    n = round(cfg.commands.duration_s * cfg.rate_hz) + 1
    t = np.arange(n) / cfg.rate_hz
    run, t_new = _time(simulate_tractor_trailer, cfg)
    base, t_base = _time(baseline_rk4, cfg, t)
    ref, t_ref = _time(reference, cfg, t)
    print(f"mixed run {cfg.commands.duration_s:.0f} s at {cfg.rate_hz:.0f} Hz ({n} steps)")
    print(f"  baseline RK4 loop : {t_base:8.3f} s")
    print(f"  simulator (new)   : {t_new:8.3f} s   speed-up x{t_base / t_new:.1f}")
    print(f"  DOP853 reference  : {t_ref:8.3f} s")
    smooth = t <= cfg.commands.boundaries_s()[1]
    for label, sel in [("first segment (smooth command)", smooth), ("whole run", t >= 0)]:
        print(f"  max |state - reference| over the {label}:")
        for i, name in enumerate(["x", "y", "yaw", "psi"]):
            e_new = np.max(np.abs(run.truth[name].to_numpy()[sel] - ref[sel, i]))
            e_base = np.max(np.abs(base[sel, i] - ref[sel, i]))
            print(f"    {name:>3}: new {e_new:.2e}   baseline {e_base:.2e}")
    print("  (jumps in the command between segments are not on the step grid's knots: both")
    print("   fixed-step schemes are first order there; the reference integrates piecewise)")
    long = patent_mixed(rate_hz=100.0, duration_s=3600.0 * args.hours)
    long_run, t_long = _time(simulate_tractor_trailer, long)
    print(
        f"{args.hours:g} h at 100 Hz ({long_run.truth.height} steps, noise on): {t_long:.2f} s "
        f"= x{t_long / t_new:.1f} the mixed run (length ratio x{long_run.truth.height / n:.1f})"
    )


if __name__ == "__main__":
    main()
