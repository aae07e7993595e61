"""Coverage of the least-squares odometry calibration on simulated logs with a 1 % wheel-radius
asymmetry: per seed, is each parameter within the precision target (radii 0.1 %, track 0.5 %)
and does its 95 % interval cover the truth? Rates with Wilson 95 % binomial intervals. Also
the false-alarm rate of discovery on clean logs and its detection rate on asymmetric ones.

    python bench/diff_drive_coverage.py [N_SEEDS] [DURATION_S]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from calib.diff_drive.data import DriveRun
from calib.diff_drive.discovery import discover
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import calibrate_lsq
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive

NOMINAL = DiffDriveParams(0.042, 0.042, 0.20)
ASYM = 0.01
TARGET = {"wheel_radius_right": 1e-3, "wheel_radius_left": 1e-3, "track_width": 5e-3}


def wilson(k: int, n: int) -> tuple[float, float]:
    if n == 0:
        return (float("nan"), float("nan"))
    z, p = 1.96, k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (c - h, c + h)


def config(true: DiffDriveParams) -> SimConfig:
    return SimConfig(
        true=true,
        nominal=NOMINAL,
        slip_std=0.005,
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
    named_asym = 0
    false_alarm = 0
    t0 = time.time()
    for seed in range(n_seeds):
        rng = np.random.default_rng(seed)
        sim = simulate_diff_drive(mixed_commands(NOMINAL, duration, rng), config(true), seed)
        run = DriveRun(sim.t, sim.wheel_right, sim.wheel_left, sim.x, sim.y, sim.yaw)
        res, fit = calibrate_lsq([run], n_boot=200, seed=seed)
        for name, e in res.parameters.items():
            within[name] += abs(e.value / truth[name] - 1) <= TARGET[name]
            cover[name] += e.ci95[0] <= truth[name] <= e.ci95[1]
        named_asym += "wheel_radius_asymmetry" in discover([run], fit, NOMINAL).named
        # clean log: nominal is the truth
        sim0 = simulate_diff_drive(
            mixed_commands(NOMINAL, duration, np.random.default_rng(10_000 + seed)),
            config(NOMINAL),
            10_000 + seed,
        )
        run0 = DriveRun(sim0.t, sim0.wheel_right, sim0.wheel_left, sim0.x, sim0.y, sim0.yaw)
        _, fit0 = calibrate_lsq([run0], n_boot=200, seed=seed)
        false_alarm += bool(discover([run0], fit0, NOMINAL).named)
        if (seed + 1) % 10 == 0:
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
    lo, hi = wilson(named_asym, n)
    print(f"discovery names wheel_radius_asymmetry: {named_asym}/{n} [{lo:.2f}, {hi:.2f}]")
    lo, hi = wilson(false_alarm, n)
    print(f"discovery names anything on clean logs:  {false_alarm}/{n} [{lo:.2f}, {hi:.2f}]")


if __name__ == "__main__":
    main()
