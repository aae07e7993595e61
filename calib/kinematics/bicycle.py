"""The kinematic bicycle model: a vehicle steered by an angle delta drives its fixed
(reference) axle on the curvature kappa = tan(delta - delta0) / wheelbase (delta0: the steering
sensor's or command's zero offset), so its yaw rate is v kappa.

Shared by every steered robot (the tractor of a tractor-trailer, a car-like robot): the
curvature and yaw rate of the model, and the wheelbase and steering offset fitted to a measured
path's curvature and the logged steering angle (a least-squares fit over the samples where the
robot moves, with a Newey-West covariance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from calib.errors import InsufficientDataError
from calib.results import Estimate
from calib.stats import Z95, bartlett_bandwidth, hac_covariance

__all__ = ["SteeringGeometry", "bicycle_curvature", "bicycle_yaw_rate", "fit_steering_geometry"]


def bicycle_curvature(steer: np.ndarray, wheelbase: float, offset: float = 0.0) -> np.ndarray:
    """Curvature (1/m) of the fixed axle's path: tan(steer - offset) / wheelbase."""
    return np.tan(steer - offset) / wheelbase


def bicycle_yaw_rate(
    v: np.ndarray, steer: np.ndarray, wheelbase: float, offset: float = 0.0
) -> np.ndarray:
    """Yaw rate (rad/s) at the fixed axle's speed ``v``: v tan(steer - offset) / wheelbase."""
    return v * bicycle_curvature(steer, wheelbase, offset)


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
        return k - bicycle_curvature(d, x[0], x[1])

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
