"""Gaussian heading-profile path planning (paper Section IV.1, Eqs. 35-37).

The heading relative to the straight line from start to goal follows Gaussians,
theta(t) = A exp(-(t - t_c)^2 / 2 sigma^2): the amplitude A sets the lateral displacement, sigma
the sharpness. With an initial heading offset (positive or negative) a first, half Gaussian
brings the heading back to the line's; a second, full one, whose amplitude is solved from the
lateral distance then left (Eqs. 36-37, here by root finding on the integrated path rather
than the paper's straight-line approximation of Fig. 2), brings the robot onto the line. With
no offset the path is the straight line. Two Gaussians of opposite sign in sequence pass an
obstacle.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

__all__ = ["GaussianPiece", "PlannedPath", "gaussian_heading", "plan_path", "speed_profile"]

Array = NDArray[np.float64]


def gaussian_heading(t: Array, A: float, sigma: float, t_c: float = 0.0) -> Array:
    """Eq. 35: A exp(-(t - t_c)^2 / (2 sigma^2)) (rad)."""
    return A * np.exp(-((np.asarray(t, dtype=float) - t_c) ** 2) / (2 * sigma**2))


@dataclass(frozen=True)
class GaussianPiece:
    """One Gaussian of the heading profile; ``half``: only its falling half (from t_c on)."""

    A: float
    sigma: float
    t_c: float
    half: bool = False

    def __call__(self, t: Array) -> Array:
        g = gaussian_heading(t, self.A, self.sigma, self.t_c)
        return np.where(t >= self.t_c, g, self.A if self.half else g)


@dataclass(frozen=True)
class PlannedPath:
    """A reference: time (s), pose (m, m, rad), speed (m/s) and yaw rate (rad/s) in the world
    frame, the Gaussians it was made of (line frame) and the line's heading."""

    t: Array
    x: Array
    y: Array
    yaw: Array
    v: Array
    omega: Array
    line_heading: float
    pieces: list[GaussianPiece] = field(default_factory=list)
    case: str = ""


def speed_profile(t: Array, v: float, duration: float, ramp_s: float) -> Array:
    """Constant speed ``v`` with linear acceleration and deceleration of ``ramp_s`` seconds."""
    up = np.clip(t / ramp_s, 0, 1)
    down = np.clip((duration - t) / ramp_s, 0, 1)
    return v * np.minimum(up, down)


def _integrate(t: Array, v: Array, rel: Array) -> tuple[Array, Array]:
    """Line-frame path of heading ``rel`` (rad) at speed ``v``: trapezoids, start at 0."""
    dt = np.diff(t)
    vx, vy = v * np.cos(rel), v * np.sin(rel)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (vx[1:] + vx[:-1]) * dt)])
    y = np.concatenate([[0.0], np.cumsum(0.5 * (vy[1:] + vy[:-1]) * dt)])
    return x, y


def plan_path(
    start: tuple[float, float, float],
    goal: tuple[float, float],
    *,
    v: float = 0.2,
    sigma: float = 0.6,
    dt: float = 0.01,
    ramp_s: float = 0.5,
    obstacle: tuple[float, float] | None = None,
) -> PlannedPath:
    """Plan from pose ``start`` (x, y, yaw) to ``goal`` (x, y).

    Args:
        v: cruise speed (m/s); the run takes about distance / v + ramp_s.
        sigma: width (s) of the Gaussians.
        dt: time step (s) of the reference.
        ramp_s: acceleration / deceleration time (s) (the paper's 0.5 s).
        obstacle: (distance along the line, lateral clearance) (m): two Gaussians of opposite
            sign shift the path by the clearance before the obstacle and back after it.
    """
    x0, y0, th0 = start
    dx, dy = goal[0] - x0, goal[1] - y0
    dist = float(np.hypot(dx, dy))
    psi = float(np.arctan2(dy, dx))
    off = float(np.angle(np.exp(1j * (th0 - psi))))
    duration = dist / v + ramp_s
    t = np.arange(0.0, duration + dt / 2, dt)
    vel = speed_profile(t, v, duration, ramp_s)
    pieces: list[GaussianPiece] = []
    if abs(off) > 1e-9:
        case = "positive" if off > 0 else "negative"
        g1 = GaussianPiece(off, sigma, 0.0, half=True)
        pieces.append(g1)
        t2 = 3 * sigma + 3 * sigma  # the first has decayed; the second is centred 3 sigma on

        def lateral(A: float) -> float:
            rel = g1(t) + gaussian_heading(t, A, sigma, t2)
            return float(_integrate(t, vel, rel)[1][-1])

        A2 = brentq(lateral, -1.4, 1.4) if lateral(-1.4) * lateral(1.4) < 0 else 0.0
        pieces.append(GaussianPiece(float(A2), sigma, t2))
    else:
        case = "zero"
    if obstacle is not None:
        s_obs, clear = obstacle
        t_obs = s_obs / v + ramp_s / 2
        tc1, tc2 = t_obs - 4 * sigma, t_obs + 4 * sigma
        base = sum((p(t) for p in pieces), np.zeros_like(t))

        def shift(A: float) -> float:
            rel = base + gaussian_heading(t, A, sigma, tc1)
            _x, y = _integrate(t, vel, rel)
            return float(np.interp(t_obs, t, y)) - clear

        A1 = brentq(shift, -1.4, 1.4) if shift(-1.4) * shift(1.4) < 0 else 0.0
        pieces += [GaussianPiece(float(A1), sigma, tc1), GaussianPiece(-float(A1), sigma, tc2)]
        case = "obstacle" if case == "zero" else case + "+obstacle"
    rel = sum((p(t) for p in pieces), np.zeros_like(t))
    xl, yl = _integrate(t, vel, rel)
    c, s = np.cos(psi), np.sin(psi)
    yaw = psi + rel
    return PlannedPath(
        t=t,
        x=x0 + c * xl - s * yl,
        y=y0 + s * xl + c * yl,
        yaw=yaw,
        v=vel,
        omega=np.gradient(yaw, t),
        line_heading=psi,
        pieces=pieces,
        case=case,
    )
