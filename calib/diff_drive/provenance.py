"""Is the logged pose ground truth, or the robot's own dead reckoning?

A diff-drive controller publishes ``/odom``: a pose integrated from the same wheel encoders the
calibration reads. Taken as ground truth it "confirms" any radii to machine precision. Its
signature: the heading is a holonomic function of the wheel angles (paper Eq. 38), so the
*whole-log* heading (never restarted) equals c_R phi_R - c_L phi_L + const to rounding, where
any real sensor (motion capture, a gyro, GPS) leaves its noise and the wheels' slip, which
accumulate over the log. The pose is taken as dead reckoning when that fit leaves less than
``DR_TOL_RAD`` (or ``DR_TOL_REL`` of the heading's excursion).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["DR_TOL_RAD", "DR_TOL_REL", "Provenance", "pose_provenance"]

DR_TOL_RAD = 1e-6
"""Whole-log heading residual (RMS, rad) below which the pose is the encoders' own dead
reckoning: motion capture is noisy at ~1e-4 rad and above, slip adds far more."""
DR_TOL_REL = 1e-6
"""The same, relative to the RMS excursion of the heading."""


@dataclass(frozen=True)
class Provenance:
    """``dead_reckoning``: the pose is reproduced by the encoders; ``heading_rms`` the
    whole-log heading residual (rad); ``note`` for people."""

    dead_reckoning: bool
    heading_rms: float
    excursion: float
    note: str

    def to_dict(self) -> dict[str, object]:
        return {
            "dead_reckoning": self.dead_reckoning,
            "heading_residual_rms_rad": self.heading_rms,
            "heading_excursion_rad": self.excursion,
            "note": self.note,
        }


def pose_provenance(
    wheel_right: ArrayLike, wheel_left: ArrayLike, yaw: ArrayLike, source: str = "the pose"
) -> Provenance:
    """Test whether ``yaw`` is dead reckoning of the wheel angles (see the module docstring)."""
    pr, pl, th = (np.asarray(a, dtype=float) for a in (wheel_right, wheel_left, yaw))
    ok = np.isfinite(pr) & np.isfinite(pl) & np.isfinite(th)
    pr, pl, th = pr[ok], pl[ok], np.unwrap(th[ok])
    if th.size < 10:
        return Provenance(False, math.nan, math.nan, "too few samples to test the pose")
    X = np.column_stack([pr - pr[0], -(pl - pl[0]), np.ones_like(pr)])
    y = th - th[0]
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    rms = float(np.sqrt(np.mean((y - X @ coef) ** 2)))
    exc = float(np.sqrt(np.mean((y - y.mean()) ** 2)))
    dr = exc > 0 and (rms < DR_TOL_RAD or rms < DR_TOL_REL * exc)
    note = (
        f"{source} is not ground truth: its heading is the wheel encoders' dead reckoning "
        f"(reproduced to {rms:.2g} rad RMS over the whole log, far below any sensor's noise); "
        "it cannot calibrate the wheels it was computed from"
        if dr
        else f"{source} is independent of the wheel encoders (whole-log heading residual "
        f"{rms:.2g} rad RMS)"
    )
    return Provenance(bool(dr), rms, exc, note)
