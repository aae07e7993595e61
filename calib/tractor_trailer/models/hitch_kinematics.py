"""Kinematics of the two-link nonholonomic robot (tractor + off-axle trailer).

Link 1 runs from the front wheel centre C1 to the joint P (length ``L1``), link 2 from P to the
rear wheel centre C2 (length ``L2``). ``psi`` is the joint angle (rad, 0 when straight, positive
when the trailer trails a left turn), ``kappa`` the path curvature of C1 (1/m), ``v`` the speed
of C1 (m/s). Trailer heading is ``yaw - psi``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "kappa_limit",
    "link_points",
    "psi_rate",
    "psi_rate_per_distance",
    "steady_state_kappa",
    "steady_state_psi",
    "steady_state_residual",
]

FloatArray = NDArray[np.float64]


def steady_state_residual(kappa: ArrayLike, psi: ArrayLike, L1: float, L2: float) -> FloatArray:
    """Implicit steady-state relation sin(psi) - kappa (L2 + L1 cos(psi)) (dimensionless)."""
    k = np.asarray(kappa, dtype=float)
    p = np.asarray(psi, dtype=float)
    return np.sin(p) - k * (L2 + L1 * np.cos(p))


def kappa_limit(L1: float, L2: float) -> float:
    """Largest |kappa| (1/m) with a steady state: kappa^2 < 1/(L2^2 - L1^2); inf if L1 >= L2."""
    d = L2 * L2 - L1 * L1
    return float(np.inf) if d <= 0 else float(1.0 / np.sqrt(d))


def steady_state_psi(kappa: ArrayLike, L1: float, L2: float) -> FloatArray:
    """Joint angle (rad) at rest for curvature ``kappa`` (1/m): closed-form root of the relation.

    sin(psi) - kappa L1 cos(psi) = kappa L2  =>  psi = atan(kappa L1) + asin(kappa L2 / r),
    r = sqrt(1 + kappa^2 L1^2). NaN where no steady state exists.
    """
    k = np.asarray(kappa, dtype=float)
    r = np.sqrt(1.0 + (k * L1) ** 2)
    s = k * L2 / r
    with np.errstate(invalid="ignore"):
        out = np.arctan(k * L1) + np.arcsin(s)
    return np.where(np.abs(s) <= 1.0, out, np.nan)


def steady_state_kappa(psi: ArrayLike, L1: float, L2: float) -> FloatArray:
    """Curvature (1/m) whose steady state is ``psi`` (rad): sin(psi) / (L2 + L1 cos(psi))."""
    p = np.asarray(psi, dtype=float)
    return np.sin(p) / (L2 + L1 * np.cos(p))


def psi_rate_per_distance(kappa: ArrayLike, psi: ArrayLike, L1: float, L2: float) -> FloatArray:
    """d psi / d s (rad/m) = kappa (1 + (L1/L2) cos psi) - sin(psi) / L2."""
    k = np.asarray(kappa, dtype=float)
    p = np.asarray(psi, dtype=float)
    return k * (1.0 + (L1 / L2) * np.cos(p)) - np.sin(p) / L2


def psi_rate(v: ArrayLike, kappa: ArrayLike, psi: ArrayLike, L1: float, L2: float) -> FloatArray:
    """d psi / d t (rad/s) = v kappa - (v sin psi - L1 v kappa cos psi) / L2."""
    return np.asarray(v, dtype=float) * psi_rate_per_distance(kappa, psi, L1, L2)


def link_points(
    x: ArrayLike, y: ArrayLike, yaw: ArrayLike, psi: ArrayLike, L1: float, L2: float
) -> tuple[FloatArray, FloatArray]:
    """World positions (m) of the joint P and the rear wheel centre C2, each shape (n, 2).

    C1 = (x, y) with heading ``yaw``; P = C1 - L1 e(yaw); C2 = P - L2 e(yaw - psi).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    yaw = np.asarray(yaw, dtype=float)
    psi = np.asarray(psi, dtype=float)
    p = np.stack([x - L1 * np.cos(yaw), y - L1 * np.sin(yaw)], axis=-1)
    th2 = yaw - psi
    c2 = np.stack([p[:, 0] - L2 * np.cos(th2), p[:, 1] - L2 * np.sin(th2)], axis=-1)
    return p, c2
