"""Instantaneous-centre construction of the two-link robot (the patent's Fig. 3), closed form.

C1 (front wheel centre, heading ``yaw``) moves on a circle of curvature ``kappa`` about the
instantaneous centre O = C1 + n1 / kappa, n1 = (-sin yaw, cos yaw) the left normal of link 1.
The joint is P = C1 - L1 e1 and the rear wheel centre C2 = P - L2 e2, e2 = e(yaw - psi).
Q is where the line O C1 meets the extension of link 2 (the line C2 P):
Q = C1 - L1 tan(psi) n1. In the steady state the triangles O Q C2 (right angle at C2) and
Q C1 P (right angle at C1) give the relation R sin(psi) = L2 + L1 cos(psi), R = 1 / kappa.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.results import json_safe
from calib.tractor_trailer.models.hitch_kinematics import link_points

__all__ = ["ICRConstruction", "icr_construction"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Default smallest |kappa| (1/m) for which O is drawn: radii beyond 1 km are hidden.
KAPPA_MIN = 1e-3
#: Smallest |cos(psi)| for which Q is defined (link 2 not parallel to the line O C1).
COS_PSI_MIN = 1e-6


@dataclass(frozen=True)
class ICRConstruction:
    """Points (m, world frame, each shape (n, 2)) and radius of the ICR construction.

    ``R`` is the signed radius 1/kappa (m, positive for left turns). ``valid`` is False where
    |kappa| is below the threshold or psi makes link 2 parallel to O C1; there O, Q and R are
    NaN (C1, P and C2 are always given).
    """

    C1: FloatArray
    P: FloatArray
    C2: FloatArray
    O: FloatArray
    Q: FloatArray
    R: FloatArray
    valid: BoolArray

    def to_dict(self) -> dict[str, Any]:
        return json_safe({k: getattr(self, k) for k in ("C1", "P", "C2", "O", "Q", "R", "valid")})


def icr_construction(
    x: ArrayLike,
    y: ArrayLike,
    yaw: ArrayLike,
    psi: ArrayLike,
    kappa: ArrayLike,
    L1: float,
    L2: float,
    *,
    kappa_min: float = KAPPA_MIN,
) -> ICRConstruction:
    """Closed-form ICR construction at every sample.

    Args:
        x, y: position of C1 (m), shape (n,).
        yaw: heading of link 1 (rad).
        psi: joint angle (rad).
        kappa: path curvature of C1 (1/m).
        L1, L2: link lengths (m).
        kappa_min: smallest |kappa| (1/m) for which O, Q and R are given.

    Returns:
        The construction; rows with ``valid`` False hold NaN in O, Q and R.
    """
    x = np.atleast_1d(np.asarray(x, dtype=float))
    y = np.atleast_1d(np.asarray(y, dtype=float))
    yaw = np.atleast_1d(np.asarray(yaw, dtype=float))
    psi = np.atleast_1d(np.asarray(psi, dtype=float))
    k = np.atleast_1d(np.asarray(kappa, dtype=float))
    c1 = np.stack([x, y], axis=-1)
    p, c2 = link_points(x, y, yaw, psi, L1, L2)
    n1 = np.stack([-np.sin(yaw), np.cos(yaw)], axis=-1)
    cos_psi = np.cos(psi)
    valid = (
        np.isfinite(k)
        & (np.abs(k) >= kappa_min)
        & (np.abs(cos_psi) >= COS_PSI_MIN)
        & np.isfinite(c1).all(axis=-1)
        & np.isfinite(psi)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(valid, 1.0 / np.where(valid, k, 1.0), np.nan)
        s_q = np.where(valid, -L1 * np.tan(psi), np.nan)
    o = c1 + r[:, None] * n1
    q = c1 + s_q[:, None] * n1
    return ICRConstruction(C1=c1, P=p, C2=c2, O=o, Q=q, R=r, valid=valid)
