"""Real arms: held-out torque on the DFKI double-pendulum runs (URDF of the folder, repaired)
beside the source's own published model, and the TIAGo torso + arm (example-robot-data 'tiago',
effort converted to torque with the source's constants, README of the folder).

For each DFKI run and cut-off, on the same last 40 % and the same filtered q, q', q'' (both
compared with the torque as logged, at the logged stamps):

* floor: the share of the logged torque above the cut-off, ||tau - tau_f|| / ||tau|| at the
  logged stamps — what no prediction from filtered motion can follow;
* logcal: identified on the first 60 % (rigid body + Coulomb + viscous), and the variants
  discovery can choose (smooth Coulomb in place of Coulomb, + torque offset), and the torque
  delayed/advanced by 10 ms against the motion;
* published: the source's equations (README; rotor inertia and gear coupling, cf atan(100 q'))
  with the model_3.0 parameters and with model_h1.0's fitted friction.

Run: python bench/manipulator_real.py"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import polars as pl
from numpy.typing import NDArray

from calib.manipulator.design import Term, make_design
from calib.manipulator.identify import IdentifyConfig, at_stamps, fit_holdout, identify_arm
from calib.manipulator.rows import compute_regressors
from calib.manipulator.serial import SerialArm, load_serial_arm
from calib.manipulator.signals import JointSignals, prepare_signals

SHARED = Path(__file__).resolve().parents[2] / "shared/realworld_arm"
Array = NDArray[np.float64]

# design_C.0 model_3.0 (README table); friction (b, cf) of model_3.0 and of model_h1.0
PUBLISHED = {
    "m1": 0.6416937799349799,
    "m2": 0.563935954099688,
    "l1": 0.2,
    "r1": 0.2,
    "r2": 0.3212669909674605,
    "I1": 0.02671076499939512,
    "I2": 0.053878129629650884,
    "Ir": 9.937281205437459e-05,
    "gr": 6.0,
    "g": 9.81,
}
FRICTION = {"3.0": ((0.001, 0.001), (0.093, 0.078)), "h1.0": ((0.0111, 0.0044), (0.0928, 0.0771))}


def published_torque(
    q: Array, qd: Array, qdd: Array, b: tuple[float, float], cf: tuple[float, float]
) -> Array:
    """The source's equations of motion (README 'Conventions'), parameters ``PUBLISHED``."""
    p = PUBLISHED
    k = p["m2"] * p["l1"] * p["r2"]
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    ir, gr = p["Ir"], p["gr"]
    m11 = p["I1"] + p["I2"] + p["m2"] * p["l1"] ** 2 + 2 * k * c2 + (gr**2 + 1) * ir
    m12 = p["I2"] + k * c2 - gr * ir
    m22 = p["I2"] + gr**2 * ir
    g1 = p["g"] * ((p["m1"] * p["r1"] + p["m2"] * p["l1"]) * np.sin(q[:, 0]))
    g2 = p["g"] * p["m2"] * p["r2"] * np.sin(q[:, 0] + q[:, 1])
    fr = np.asarray(b) * qd + np.asarray(cf) * np.arctan(100 * qd)
    t1 = m11 * qdd[:, 0] + m12 * qdd[:, 1] - k * s2 * (2 * qd[:, 0] + qd[:, 1]) * qd[:, 1] + g1 + g2
    t2 = m12 * qdd[:, 0] + m22 * qdd[:, 1] + k * s2 * qd[:, 0] ** 2 + g2
    return np.stack([t1, t2], axis=1) + fr


def _ratio(meas: Array, pred: Array) -> float:
    return float(np.linalg.norm(pred - meas) / np.linalg.norm(meas))


def _published(sig: JointSignals, friction: str) -> float:
    cut = round(0.6 * len(sig))
    pred = published_torque(sig.q[cut:], sig.qd[cut:], sig.qdd[cut:], *FRICTION[friction])
    _, meas, at = at_stamps(sig, pred, cut)
    return _ratio(meas, at)


def _variant(arm: SerialArm, sig: JointSignals, terms: tuple[Term, ...], fc: float) -> float:
    reg = compute_regressors(make_design(arm, terms), sig)
    return fit_holdout(reg, IdentifyConfig(terms=terms, cutoff_hz=fc))[1].ratio


def dfki() -> None:
    folder = SHARED / "dfki_double_pendulum"
    arm = load_serial_arm(
        str(folder / "design_C.0_model_3.1_acrobot.urdf"), ("Joint1", "Joint2"), 2
    )
    print("DFKI held-out torque error, % of the torque RMS (last 40 %, at the logged stamps)")
    print(
        "run | cut-off | floor | logcal (per joint N·m) | smooth-Fc | +offset | tau -10 ms | "
        "tau +10 ms | published 3.0 | published h1.0 | Fc, Fv joint 1 (± 95 %)"
    )
    for f in sorted(folder.glob("*.csv")):
        df = pl.read_csv(f)
        t = df["t"].to_numpy()
        q = df.select("q1", "q2").to_numpy()
        tau = df.select("tau1", "tau2").to_numpy()
        for fc in (5.0, 10.0):
            r = identify_arm(arm, t, q, tau, IdentifyConfig(cutoff_hz=fc))
            sig = r.sig
            cut = round(0.6 * len(sig))
            _, logged, smooth_tau = at_stamps(sig, sig.tau_f[cut:], cut)
            floor = _ratio(logged, smooth_tau)
            smooth = _variant(arm, sig, (Term.COULOMB_SMOOTH, Term.VISCOUS), fc)
            offset = _variant(arm, sig, (Term.COULOMB, Term.VISCOUS, Term.OFFSET), fc)
            shifted = []
            for lag in (-0.01, 0.01):  # torque sample of t + lag against the motion at t
                tau_l = np.stack([np.interp(t + lag, t, tau[:, j]) for j in range(2)], axis=1)
                s_l = prepare_signals(t, q, tau_l, cutoff_hz=fc)
                shifted.append(_variant(arm, s_l, (Term.COULOMB, Term.VISCOUS), fc))
            est = r.recommended.parameters
            fric = [e for name, e in est.items() if name in ("Fc[Joint1]", "Fv[Joint1]")]
            fric_txt = ", ".join(f"{e.value:.3f} ± {1.96 * e.std:.3f}" for e in fric)
            print(
                f"  {f.stem[-2:]} | {fc:4.0f} Hz | {100 * floor:5.1f} | "
                f"{100 * r.holdout.ratio:5.1f} "
                f"({' '.join(f'{v:.3f}' for v in r.holdout.rms)}) | {100 * smooth:5.1f} | "
                f"{100 * offset:5.1f} | {100 * shifted[0]:5.1f} | {100 * shifted[1]:5.1f} | "
                f"{100 * _published(sig, '3.0'):5.1f} | {100 * _published(sig, 'h1.0'):5.1f} | "
                f"{fric_txt}",
                flush=True,
            )


def tiago() -> None:
    df = pl.read_csv(SHARED / "tiago_arm/tiago_arm_identification.csv")
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


def main() -> None:
    t0 = time.time()
    dfki()
    tiago()
    print(f"took {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
