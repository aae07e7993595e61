"""Real arms: held-out torque ratio on the DFKI double-pendulum runs (URDF of the folder, repaired)
and the TIAGo torso + arm (example-robot-data 'tiago', effort converted to torque with the
source's constants, README of the folder). Run: python bench/manipulator_real.py"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import polars as pl

from calib.manipulator.identify import IdentifyConfig, identify_arm
from calib.manipulator.serial import load_serial_arm

SHARED = Path(__file__).resolve().parents[2] / "shared/realworld_arm"


def main() -> None:
    t0 = time.time()
    dfki = SHARED / "dfki_double_pendulum"
    urdf = str(dfki / "design_C.0_model_3.1_acrobot.urdf")
    arm = load_serial_arm(urdf, ("Joint1", "Joint2"), 2)
    print("DFKI run | cut-off | held-out ratio % | per joint RMS (N·m)")
    for f in sorted(dfki.glob("*.csv")):
        df = pl.read_csv(f)
        t = df["t"].to_numpy()
        q = df.select("q1", "q2").to_numpy()
        tau = df.select("tau1", "tau2").to_numpy()
        for fc in (5.0, 10.0):
            r = identify_arm(arm, t, q, tau, IdentifyConfig(cutoff_hz=fc))
            print(
                f"  {f.stem[-2:]} | {fc:4.0f} Hz | {100 * r.holdout.ratio:5.1f} | "
                f"{' '.join(f'{v:.3f}' for v in r.holdout.rms)}",
                flush=True,
            )
    tiago = SHARED / "tiago_arm/tiago_arm_identification.csv"
    df = pl.read_csv(tiago)
    names = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    arm = load_serial_arm("tiago", names, 8)
    ratio = np.array([1, 100, 100, 100, 100, 336, 336, 336.0])
    km = np.array([1, 0.136, 0.136, -0.087, -0.087, -0.0613, -0.0613, -0.0613])
    eff = df.select("effort1_raw", *(f"current{i}" for i in range(2, 9))).to_numpy()
    tau = eff * ratio * km
    tau[:, 0] += 9.81 * 18.906  # the source's static load on the torso
    t = df["t"].to_numpy()
    q = df.select(*(f"q{i}" for i in range(1, 9))).to_numpy()
    keep = slice(921, 6791)  # the source's moving part
    r = identify_arm(arm, t[keep], q[keep], tau[keep], IdentifyConfig(cutoff_hz=2.0))
    print(
        f"TIAGo: held-out ratio {100 * r.holdout.ratio:.1f} %, per joint RMS "
        f"{' '.join(f'{v:.3f}' for v in r.holdout.rms)}; torque RMS "
        f"{' '.join(f'{v:.3f}' for v in r.holdout.torque_rms)}; condition "
        f"{r.condition_number:.3g}; determined {int(r.wls.identifiable.sum())}/{len(r.wls.theta)}"
    )
    print(f"took {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
