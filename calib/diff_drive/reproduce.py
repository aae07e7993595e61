"""``logcal reproduce wmr``: Table 1 of Kim, Chung and Park (1997), the 4-wheeled 2-DOF mobile
robot, recomputed in kind beside the published values.

The paper does not print its robot's dimensions, gains, speeds or initial offsets, so the
scenario below is ours (stated in ``SCENARIO``): the robot starts on the line to the goal with a
heading offset of +20 deg (Case 1), 0 (Case 2) or -20 deg (Case 3); "feedback only" tracks
the straight line from start to goal at the cruise speed, "path planning" tracks the Gaussian
heading-profile path planned from the actual start pose. Both use the paper's own tracking law
(Eqs. 40-44, ``law="paper"`` in :mod:`calib.diff_drive.tracker`; the control-point law is the
alternative), a robot whose real wheels are 0.2 % larger than the controller's nominal ones
(equal on both sides) and quantised encoders, so that dead reckoning and truth part.

Motor limit: a Robotis Dynamixel XL430-W250 (the TurtleBot3 Burger's wheel actuator), no-load
speed 57 rev/min at its recommended 11.1 V, i.e. 5.97 rad/s; with 50 mm wheels the 0.2 m/s
cruise takes 4 rad/s, two thirds of it, as a small robot's drive is usually sized.

Gains, from a stated criterion (not fitted to the table): with a velocity-commanded
(kinematic) robot the paper's law makes heading and along-track error first-order loops,
e' = -Kp e, so Kp is their bandwidth. Kp is the largest bandwidth for which the design
disturbance, the 20 deg heading offset of Cases 1 and 3, does not saturate the motors at
cruise speed: Kp * 20 deg * l_a / R = w_max - v / R. Kd = 0: on a first-order loop Eq. 41's
derivative term can only slow it (by 1 / (1 + Kd T)) and passes encoder-count steps straight to
the motors.

Measured per case (against the true pose):
* accumulated X / Y error: mean |true - reference| over the run (m), the reference being the
  one tracked (the line, or the planned path);
* heading convergence time: time after which |yaw - line heading| stays below 1 deg (s);
* position convergence time: time after which the distance to the line stays below 1 cm (s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.planner import plan_path
from calib.diff_drive.tracker import TrackerGains, TrackingLaw, TrackingRun, track
from calib.results import json_safe

__all__ = ["PUBLISHED_TABLE1", "SCENARIO", "WmrRow", "WmrTable", "reproduce_wmr"]

PUBLISHED_TABLE1: dict[str, dict[str, float]] = {
    "feedback only": {"x_err": 0.04, "y_err": 0.04, "t_heading": 12.0, "t_position": 14.0},
    "planned, case 1": {"x_err": 0.012, "y_err": 0.0118, "t_heading": 4.0, "t_position": 4.0},
    "planned, case 2": {"x_err": 0.0118, "y_err": 0.0118, "t_heading": 0.0, "t_position": 0.0},
    "planned, case 3": {"x_err": 0.013, "y_err": 0.013, "t_heading": 4.0, "t_position": 4.0},
}
"""Table 1 as printed (m, m, s, s). The planned rows' convergence columns are printed as one
number per case (4, 0, 4); it is given here for both times."""

W_MAX_RAD_S = 57.0 * 2 * np.pi / 60
"""Dynamixel XL430-W250 no-load speed at 11.1 V (57 rev/min), the wheel-rate limit (rad/s)."""

_NOMINAL = DiffDriveParams(0.05, 0.05, 0.30)
_SPEED = 0.2
_OFFSET = float(np.deg2rad(20.0))


def design_kp(nominal: DiffDriveParams, speed: float, heading_offset: float, w_max: float) -> float:
    """The largest heading bandwidth (1/s) at which a ``heading_offset`` (rad) error does not
    drive a wheel past ``w_max`` (rad/s) at cruise ``speed`` (m/s)."""
    headroom = w_max - speed / min(nominal.r_R, nominal.r_L)
    if headroom <= 0:
        raise ValueError("the cruise speed already needs more than the motor's limit")
    return float(headroom * min(nominal.r_R, nominal.r_L) / (nominal.half_track * heading_offset))


SCENARIO: dict[str, Any] = {
    "nominal": _NOMINAL,
    "true": DiffDriveParams(0.05 * 1.002, 0.05 * 1.002, 0.30),
    "goal": (4.0, 0.0),
    "speed_mps": _SPEED,
    "sigma_s": 0.6,
    "heading_offsets_rad": {"case 1": _OFFSET, "case 2": 0.0, "case 3": -_OFFSET},
    "gains": TrackerGains(
        kp=design_kp(_NOMINAL, _SPEED, _OFFSET, W_MAX_RAD_S), kd=0.0, l_c=0.1, w_max=W_MAX_RAD_S
    ),
    "counts_per_rev": 2000,
    "dt_s": 0.01,
    "heading_tol_rad": np.deg2rad(1.0),
    "position_tol_m": 0.01,
}


@dataclass(frozen=True)
class WmrRow:
    """One row of the table: ours and the published values."""

    name: str
    x_err: float
    y_err: float
    t_heading: float
    t_position: float
    published: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "name": self.name,
                "ours": {
                    "x_err_m": self.x_err,
                    "y_err_m": self.y_err,
                    "t_heading_s": self.t_heading,
                    "t_position_s": self.t_position,
                },
                "published": dict(self.published),
            }
        )


@dataclass(frozen=True)
class WmrTable:
    """The reproduced table, the runs behind it and notes."""

    rows: list[WmrRow]
    runs: dict[str, TrackingRun] = field(default_factory=dict, repr=False)
    notes: list[str] = field(default_factory=list)
    law: str = "paper"

    def to_dict(self) -> dict[str, Any]:
        scen = {
            k: (v.as_dict() if isinstance(v, DiffDriveParams) else v)
            for k, v in SCENARIO.items()
            if k != "gains"
        }
        g = SCENARIO["gains"]
        scen["gains"] = {"kp_per_s": g.kp, "kd": g.kd, "l_c_m": g.l_c, "w_max_rad_s": g.w_max}
        return json_safe(
            {
                "law": self.law,
                "rows": [r.to_dict() for r in self.rows],
                "scenario": scen,
                "notes": self.notes,
            }
        )


def _settle(t: np.ndarray, err: np.ndarray, tol: float) -> float:
    """Time after which |err| stays below ``tol`` (inf if it never settles)."""
    bad = np.flatnonzero(np.abs(err) > tol)
    if bad.size == 0:
        return 0.0
    if bad[-1] >= t.size - 1:
        return float("inf")
    return float(t[bad[-1] + 1])


def _row(name: str, run: TrackingRun, published: dict[str, float]) -> WmrRow:
    ref, sc = run.reference, SCENARIO
    psi = float(np.arctan2(sc["goal"][1], sc["goal"][0]))
    lateral = -np.sin(psi) * run.x + np.cos(psi) * run.y
    return WmrRow(
        name=name,
        x_err=float(np.mean(np.abs(run.x - ref.x))),
        y_err=float(np.mean(np.abs(run.y - ref.y))),
        t_heading=_settle(run.t, run.yaw - psi, sc["heading_tol_rad"]),
        t_position=_settle(run.t, lateral, sc["position_tol_m"]),
        published=published,
    )


def reproduce_wmr(law: TrackingLaw = "paper") -> WmrTable:
    """Run the four tracking cases plus feedback only with the tracking ``law`` and compare
    with Table 1."""
    sc = SCENARIO
    rows, runs = [], {}
    line = plan_path((0.0, 0.0, 0.0), sc["goal"], v=sc["speed_mps"], dt=sc["dt_s"])
    fb_rows = []

    def go(ref: Any, start: tuple[float, float, float]) -> TrackingRun:
        return track(
            ref, start, sc["true"], sc["nominal"], sc["gains"], sc["counts_per_rev"], law=law
        )

    for case, off in sc["heading_offsets_rad"].items():
        start = (0.0, 0.0, float(off))
        if off != 0:
            fb = go(line, start)
            runs[f"feedback only, {case}"] = fb
            fb_rows.append(_row(f"feedback only, {case}", fb, PUBLISHED_TABLE1["feedback only"]))
        ref = plan_path(start, sc["goal"], v=sc["speed_mps"], sigma=sc["sigma_s"], dt=sc["dt_s"])
        run = go(ref, start)
        runs[f"planned, {case}"] = run
        rows.append(_row(f"planned, {case}", run, PUBLISHED_TABLE1[f"planned, {case}"]))
    obstacle = plan_path(
        (0.0, 0.0, 0.0),
        sc["goal"],
        v=sc["speed_mps"],
        sigma=sc["sigma_s"],
        dt=sc["dt_s"],
        obstacle=(2.0, 0.3),
    )
    runs["planned, obstacle"] = go(obstacle, (0.0, 0.0, 0.0))
    g = sc["gains"]
    sat = {
        name: float(np.mean(np.maximum(np.abs(r.w_right), np.abs(r.w_left)) >= g.w_max * 0.999))
        for name, r in runs.items()
    }
    law_text = (
        "the paper's law (Eqs. 40-44: PD on the axle's world pose error, M^T, inverse "
        "kinematics; no lateral feedback)"
        if law == "paper"
        else f"the control-point law (l_c = {g.l_c:g} m)"
    )
    notes = [
        f"Tracking: {law_text}; Kp = {g.kp:.2f} /s (largest bandwidth at which a 20 deg heading "
        f"error does not saturate the motors at cruise), Kd = {g.kd:g}.",
        f"Motor limit {g.w_max:.2f} rad/s (Dynamixel XL430-W250, 57 rev/min at 11.1 V); "
        "share of steps at the limit: "
        + ", ".join(f"{k} {v:.0%}" for k, v in sat.items() if v > 0)
        + ("" if any(v > 0 for v in sat.values()) else "none"),
        "Scenario ours (the paper prints no dimensions, gains or offsets): "
        f"R = 50 mm, b = 300 mm, {sc['speed_mps']:g} m/s, sigma {sc['sigma_s']:g} s, "
        "heading offsets ±20 deg, 4 m to the goal, real wheels 0.2 % larger than nominal, "
        f"{sc['counts_per_rev']} counts/rev.",
        "Accumulated error: mean |true - tracked reference|; convergence: time after which the "
        "heading stays within 1 deg of the line and the distance to the line within 1 cm "
        "('never': not within the run).",
        "Obstacle case (two Gaussians, 0.3 m clearance at 2 m) simulated; it has no row in "
        "Table 1.",
    ]
    if law == "paper":
        stuck = [r for r in fb_rows if math.isinf(r.t_position)]
        if stuck:
            psi = float(np.arctan2(sc["goal"][1], sc["goal"][0]))
            ends = [
                abs(-np.sin(psi) * runs[r.name].x[-1] + np.cos(psi) * runs[r.name].y[-1])
                for r in stuck
            ]
            notes.append(
                "Feedback only never brings the position back to the line: the law feeds back "
                "the heading error and the along-track error only, so the lateral offset built "
                "while the heading converges stays (end offsets "
                + ", ".join(f"{o * 100:.1f} cm" for o in ends)
                + "). The planned path starts at the robot's own heading and is drivable, so "
                "there is nothing lateral to correct."
            )
    return WmrTable(fb_rows + rows, runs, notes, law)
