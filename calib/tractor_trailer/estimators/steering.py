"""Wheelbase and steering offset of a steered tractor from its measured path.

A tractor steered by an angle delta drives its reference axle on curvature
kappa = tan(delta - delta0) / wheelbase (delta0: the steering sensor's or command's zero
offset). With the path's curvature measured (from a pose: d theta / ds) and the steering angle
logged, (wheelbase, delta0) follow from a least-squares fit over the samples where the robot
moves, with a Newey-West covariance. Used when the log or the channel map gives no wheelbase,
and as a check of the one given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from calib.errors import InsufficientDataError
from calib.results import Estimate
from calib.stats import bartlett_bandwidth, hac_covariance
from calib.tractor_trailer.estimators.identifiability import Z95

__all__ = ["SteeringGeometry", "fit_steering_geometry"]


@dataclass(frozen=True)
class SteeringGeometry:
    """Fitted wheelbase (m) and steering zero offset (rad), with 95 % intervals."""

    wheelbase: Estimate
    offset: Estimate
    samples: int

    def to_dict(self) -> dict[str, object]:
        # JSON key "steering_offset" (the field is ``offset``): kept for JSON readers
        return {
            "wheelbase": self.wheelbase.to_dict(),
            "steering_offset": self.offset.to_dict(),
            "samples": self.samples,
        }

    def report(self) -> str:
        return f"Steering geometry from the path: {self.wheelbase.report()}; {self.offset.report()}"


def fit_steering_geometry(
    kappa_path: ArrayLike, steer_rad: ArrayLike, *, max_abs_steer_rad: float = 1.2
) -> SteeringGeometry:
    """Fit kappa = tan(delta - delta0) / wheelbase.

    Args:
        kappa_path: measured curvature of the tractor's path (1/m), NaN where unknown.
        steer_rad: steering angle at the same instants (rad).
        max_abs_steer_rad: samples steered beyond this (near saturation) are left out.

    Raises:
        InsufficientDataError: fewer than 20 usable samples, or the steering never varies.
    """
    k = np.asarray(kappa_path, dtype=float).ravel()
    d = np.asarray(steer_rad, dtype=float).ravel()
    ok = np.isfinite(k) & np.isfinite(d) & (np.abs(d) < max_abs_steer_rad)
    k, d = k[ok], d[ok]
    if k.size < 20:
        raise InsufficientDataError(f"steering geometry: {k.size} usable samples; need 20")
    if np.ptp(d) < 0.02:
        raise InsufficientDataError("steering geometry: the steering angle hardly varies")
    slope = np.polyfit(np.tan(d), k, 1)[0]
    wb0 = 1.0 / slope if slope > 0 and np.isfinite(slope) else 1.0

    def resid(x: np.ndarray) -> np.ndarray:
        return k - np.tan(d - x[1]) / x[0]

    sol = least_squares(resid, [wb0, 0.0], bounds=([1e-3, -0.5], [100.0, 0.5]))
    r = sol.fun
    J = sol.jac
    cov = hac_covariance(J, r, bartlett_bandwidth(r))
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))

    def est(name: str, value: float, s: float, unit: str) -> Estimate:
        half = Z95 * s
        ok_ = bool(math.isfinite(s) and s > 0 and half <= 0.1 * max(abs(value), 0.05))
        return Estimate(
            name,
            value,
            s,
            (value - half, value + half),
            ok_,
            unit,
            "tan(steer - offset) / wheelbase fitted to the path's curvature",
        )

    return SteeringGeometry(
        est("wheelbase", float(sol.x[0]), float(sd[0]), "m"),
        est("steering_offset", float(sol.x[1]), float(sd[1]), "rad"),
        int(k.size),
    )
