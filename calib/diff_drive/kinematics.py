"""Sensed forward and actuated inverse kinematics of a differential drive (paper Eqs. 18, 24),
and the control point ahead of the axle (Eqs. 31-34) that makes the robot controllable."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DiffDriveParams",
    "control_point_inverse",
    "control_point_velocity",
    "forward",
    "inverse",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DiffDriveParams:
    """Wheel radii ``r_R``, ``r_L`` (m) and track width ``b`` (m, wheel contact to contact)."""

    r_R: float
    r_L: float
    b: float

    @property
    def half_track(self) -> float:
        """The paper's l_a (m)."""
        return self.b / 2.0

    @property
    def c_R(self) -> float:
        """Heading gain of the right wheel, r_R / b (rad of yaw per rad of wheel)."""
        return self.r_R / self.b

    @property
    def c_L(self) -> float:
        """Heading gain of the left wheel, r_L / b."""
        return self.r_L / self.b

    def as_dict(self) -> dict[str, float]:
        return {
            "wheel_radius_right": self.r_R,
            "wheel_radius_left": self.r_L,
            "track_width": self.b,
        }


def forward(params: DiffDriveParams, w_right: ArrayLike, w_left: ArrayLike) -> tuple[Array, Array]:
    """Body speed v (m/s) and yaw rate omega (rad/s) from wheel rates (rad/s): sensed forward
    kinematics, v = (r_R w_R + r_L w_L) / 2, omega = (r_R w_R - r_L w_L) / b."""
    wr = np.asarray(w_right, dtype=float)
    wl = np.asarray(w_left, dtype=float)
    v = 0.5 * (params.r_R * wr + params.r_L * wl)
    omega = (params.r_R * wr - params.r_L * wl) / params.b
    return v, omega


def inverse(params: DiffDriveParams, v: ArrayLike, omega: ArrayLike) -> tuple[Array, Array]:
    """Wheel rates (rad/s, right and left) that give body speed ``v`` and yaw rate ``omega``:
    actuated inverse kinematics, w_R = (v + omega b/2) / r_R, w_L = (v - omega b/2) / r_L."""
    vv = np.asarray(v, dtype=float)
    om = np.asarray(omega, dtype=float)
    return (vv + om * params.half_track) / params.r_R, (vv - om * params.half_track) / params.r_L


def control_point_velocity(
    v: ArrayLike, omega: ArrayLike, yaw: ArrayLike, l_c: float
) -> tuple[Array, Array]:
    """World velocity (m/s) of the point ``l_c`` (m) ahead of the axle centre (paper Eq. 32)."""
    vv, om, th = (np.asarray(a, dtype=float) for a in (v, omega, yaw))
    return vv * np.cos(th) - l_c * om * np.sin(th), vv * np.sin(th) + l_c * om * np.cos(th)


def control_point_inverse(
    ux: ArrayLike, uy: ArrayLike, yaw: ArrayLike, l_c: float
) -> tuple[Array, Array]:
    """Body speed and yaw rate that move the control point at world velocity (ux, uy): the
    world velocity rotated into the body frame (paper Eq. 42) and divided by the Jacobian of
    Eq. 31, which is invertible for l_c != 0 (at the axle centre it is singular, Eq. 30)."""
    if l_c == 0:
        raise ValueError("the control point must lie ahead of (or behind) the axle: l_c != 0")
    x, y, th = (np.asarray(a, dtype=float) for a in (ux, uy, yaw))
    c, s = np.cos(th), np.sin(th)
    return c * x + s * y, (-s * x + c * y) / l_c
