"""Odometry + IMU discovery over many simulated logs: per kind of physics (a constant gain, a
gain growing with turn rate, with speed, the skid-steer ICR slip, a gyro reading outside the
catalogue), how often the right catalogue name is given and nothing else, how often the final
model explains the log, and how often the reported gain's interval holds the true turn-weighted
mean gain (when a gain is reported at all). Each log draws its own strengths around the kind's
nominal ones, so that the counts are not of one tuned case.

    python bench/odom_imu_study.py [--n 20] [--seed 100]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from calib.diff_drive.odom_imu import analyze_odom_imu
from calib.diff_drive.odom_imu.windows import MIN_TURN_RAD_S, windows
from calib.diff_drive.sim import OdomImuSimConfig, simulate_odom_imu


@dataclass(frozen=True)
class Kind:
    name: str
    expect: frozenset[str]
    """The names a right answer gives (exactly)."""
    config: Callable[[np.random.Generator], OdomImuSimConfig]
    gyro_extra: float = 0.0
    """A gyro reading + extra |true rate| (outside the catalogue), times a draw in [0.5, 1.5]."""


def _g(rng: np.random.Generator) -> float:
    return float(rng.uniform(1.05, 1.6))


KINDS = (
    Kind("constant gain", frozenset({"effective_track"}), lambda r: OdomImuSimConfig(gain=_g(r))),
    Kind(
        "turn slip",
        frozenset({"effective_track", "turn_slip"}),
        lambda r: OdomImuSimConfig(gain=_g(r), turn_slip=float(r.uniform(0.15, 0.4))),
    ),
    Kind(
        "speed slip",
        frozenset({"effective_track", "speed_slip"}),
        lambda r: OdomImuSimConfig(gain=_g(r), speed_slip=float(r.uniform(0.2, 0.6))),
    ),
    Kind(
        "ICR slip",
        frozenset({"icr_slip"}),
        lambda r: OdomImuSimConfig(
            gain=_g(r), icr_turn=float(r.uniform(0.05, 0.15)), icr_joint=float(r.uniform(0.1, 0.3))
        ),
    ),
    Kind(
        "gyro |rate| term (uncatalogued)",
        frozenset({"effective_track"}),
        lambda r: OdomImuSimConfig(gain=_g(r)),
        gyro_extra=0.08,
    ),
)


def _true_mean_gain(t: np.ndarray, odo: np.ndarray, true: np.ndarray, v: np.ndarray) -> float:
    """The turn-weighted mean gain as the analysis defines it: total |odometry yaw change| over
    total |true yaw change| on the windows that turn."""
    w = windows(t, odo, true, v)
    use = w.rate >= MIN_TURN_RAD_S
    return float(np.sum(np.abs(w.odo[use])) / np.sum(np.abs(w.gyro[use])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="logs per kind")
    ap.add_argument("--seed", type=int, default=100)
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(
        f"{'kind':34s} {'right names':>12s} {'explains':>9s} {'gain reported':>14s} "
        f"{'covers truth':>13s} {'described':>10s}"
    )
    for k, kind in enumerate(KINDS):
        right = explains = reported = covers = described = 0
        for i in range(args.n):
            rng = np.random.default_rng([args.seed, k, i])
            cfg = kind.config(rng)
            sim = simulate_odom_imu(cfg, seed=int(rng.integers(1 << 31)))
            gyro = sim.gyro_z + kind.gyro_extra * float(rng.uniform(0.5, 1.5)) * np.abs(
                sim.omega_true
            )
            r = analyze_odom_imu(sim.t, sim.odom_omega, gyro, odom_v=sim.odom_v)
            right += set(r.named) == kind.expect
            explains += r.final_adequacy.explains
            d = None if r.explained is None else r.explained.description
            described += d is not None and d.accepted
            g = r.recommended_gain()
            if g.identifiable and math.isfinite(g.value):
                reported += 1
                truth = _true_mean_gain(sim.t, sim.odom_omega, sim.omega_true, sim.odom_v)
                covers += g.ci95[0] <= truth <= g.ci95[1]
        n = args.n
        print(
            f"{kind.name:34s} {right:>5d} / {n:<4d} {explains:>4d} / {n:<3d} "
            f"{reported:>6d} / {n:<5d} {covers:>5d} / {reported:<5d} {described:>4d} / {n:<3d}"
        )
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
