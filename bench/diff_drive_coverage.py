"""Coverage of the least-squares odometry calibration on simulated logs with a 1 % wheel-radius
asymmetry: per seed, is each parameter within the precision target (radii 0.1 %, track 0.5 %)
and does its 95 % interval cover the truth? Rates with Wilson 95 % binomial intervals. Also
discovery: its false-alarm rate on clean logs (any effect, and per effect), what it names on
the asymmetric logs, and on logs with speed-proportional wheel slip (SLIP per m/s, radii and
track nominal). Clean and slip logs use seeds apart from the asymmetric ones.

    python bench/diff_drive_coverage.py [N_SEEDS] [DURATION_S]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from calib.diff_drive.data import DriveRun
from calib.diff_drive.discovery import discover
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import LsqFit, calibrate_lsq
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive

NOMINAL = DiffDriveParams(0.042, 0.042, 0.20)
ASYM = 0.01
SLIP = 0.05
"""Speed-proportional slip of the slip logs: 5 % of wheel travel lost per m/s (2 % at the
0.4 m/s top speed of the mixed driving), the order of a rubber wheel on a hard floor."""
EFFECTS = ("wheel_radius_asymmetry", "effective_track", "wheel_slip")
TARGET = {"wheel_radius_right": 1e-3, "wheel_radius_left": 1e-3, "track_width": 5e-3}


def wilson(k: int, n: int) -> tuple[float, float]:
    if n == 0:
        return (float("nan"), float("nan"))
    z, p = 1.96, k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, c - h), min(1.0, c + h))


def config(true: DiffDriveParams, slip_per_speed: float = 0.0) -> SimConfig:
    return SimConfig(
        true=true,
        nominal=NOMINAL,
        slip_std=0.005,
        slip_per_speed=slip_per_speed,
        counts_per_rev=2797,  # 43.7 gear x 64 counts: the OptiOdom robot
        pose_noise=(0.001, 0.001, 0.002),
    )


def main() -> None:
    n_seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 60
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 180.0
    k = 1 + ASYM
    true = DiffDriveParams(2 * 0.042 * k / (1 + k), 2 * 0.042 / (1 + k), 0.203)
    truth = {"wheel_radius_right": true.r_R, "wheel_radius_left": true.r_L, "track_width": true.b}
    within = dict.fromkeys(truth, 0)
    cover = dict.fromkeys(truth, 0)
    named = {lab: dict.fromkeys(EFFECTS, 0) for lab in ("asym", "clean", "slip")}
    anything = dict.fromkeys(("asym", "clean", "slip"), 0)
    t0 = time.time()

    def log_of(true_p: DiffDriveParams, s: int, slip: float = 0.0) -> DriveRun:
        cmd = mixed_commands(NOMINAL, duration, np.random.default_rng(s))
        sim = simulate_diff_drive(cmd, config(true_p, slip), s)
        return DriveRun(sim.t, sim.wheel_right, sim.wheel_left, sim.x, sim.y, sim.yaw)

    def tally(label: str, run: DriveRun, fit: LsqFit) -> None:
        got = discover([run], fit, NOMINAL).named
        anything[label] += bool(got)
        for e in got:
            named[label][e] += 1

    for seed in range(n_seeds):
        run = log_of(true, seed)
        res, fit = calibrate_lsq([run], n_boot=200, seed=seed)
        for name, e in res.parameters.items():
            within[name] += abs(e.value / truth[name] - 1) <= TARGET[name]
            cover[name] += e.ci95[0] <= truth[name] <= e.ci95[1]
        tally("asym", run, fit)
        run0 = log_of(NOMINAL, 10_000 + seed)  # clean log: nominal is the truth
        tally("clean", run0, calibrate_lsq([run0], n_boot=200, seed=seed)[1])
        run_s = log_of(NOMINAL, 50_000 + seed, SLIP)
        tally("slip", run_s, calibrate_lsq([run_s], n_boot=200, seed=seed)[1])
        if (seed + 1) % 25 == 0:
            print(f"  {seed + 1}/{n_seeds} seeds, {time.time() - t0:.0f} s", flush=True)
    n = n_seeds
    print(
        f"\n{n} seeds, {duration:g} s mixed driving, asymmetry {ASYM:.0%}, slip 0.5 %, "
        "2797 counts/rev, pose noise 1 mm / 2 mrad"
    )
    print(f"{'parameter':20s} {'within target':>24s} {'95 % interval covers':>26s}")
    for name in truth:
        lo, hi = wilson(within[name], n)
        clo, chi = wilson(cover[name], n)
        print(
            f"{name:20s} {within[name]:3d}/{n} [{lo:.2f}, {hi:.2f}] (±{TARGET[name]:.1%})"
            f"   {cover[name]:3d}/{n} [{clo:.2f}, {chi:.2f}]"
        )
    print("\ndiscovery: logs naming each effect (Wilson 95 %)")
    print(f"{'log':28s}" + "".join(f"{e:>28s}" for e in EFFECTS) + f"{'anything':>20s}")
    labels = {
        "clean": "clean (false alarms)",
        "asym": f"asymmetry {ASYM:.0%}",
        "slip": f"slip {SLIP:.0%} per m/s",
    }
    for lab, title in labels.items():
        cells = []
        for eff in [*EFFECTS, "anything"]:
            c = anything[lab] if eff == "anything" else named[lab][eff]
            lo, hi = wilson(c, n)
            cells.append(f"{c:3d}/{n} [{lo:.3f}, {hi:.3f}]")
        print(f"{title:28s}" + "".join(f"{c:>28s}" for c in cells[:-1]) + f" {cells[-1]:>20s}")


if __name__ == "__main__":
    main()
