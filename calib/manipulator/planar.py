"""The planar 2-link arm in a vertical plane (JKROS 2012, METHODS.md §2), written out by hand.

Angles from the horizontal, ``q2`` relative to link 1, gravity along -y. With link lengths
``l1, l2``, masses ``m1, m2``, centre-of-mass distances ``r1, r2`` and inertias about the centres
of mass ``I1, I2``, the dynamics are linear in five rigid-body parameters

    a1 = I1 + m1 r1^2 + m2 l1^2,  a2 = I2 + m2 r2^2,  a3 = m2 l1 r2,
    a4 = m1 r1 + m2 l1,           a5 = m2 r2,

    M = [[a1 + a2 + 2 a3 c2, a2 + a3 c2], [a2 + a3 c2, a2]],
    C qd = a3 s2 [-(2 qd1 qd2 + qd2^2), qd1^2],
    tau_g = g [a4 c1 + a5 c12, a5 c12].

A payload of mass M held at the tool point adds ``M * (l1^2, l2^2, l1 l2, l1, l2)`` to (a1..a5):
the data see it only through those sums (it is regrouped into the base parameters).

Hand-written because the paper's arm is the reference of its own reproduction and the tests need
its dynamics in closed form (mass matrix, Coriolis) to check the regressors exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.model import ParameterInfo

__all__ = ["PAPER_ARM", "Planar2Link", "Planar2Params"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Planar2Params:
    """Physical parameters of the planar arm (SI units); ``payload`` is a point mass (kg) at the
    tip. Friction is not part of the rigid body: see :mod:`calib.manipulator.friction`."""

    l1: float = 0.5
    l2: float = 0.5
    m1: float = 1.0
    m2: float = 1.0
    r1: float = 0.2
    r2: float = 0.2
    I1: float = 0.05
    I2: float = 0.05
    payload: float = 0.0
    g: float = 9.8

    def theta(self, with_payload: bool = True) -> Array:
        """(a1..a5), the payload included when ``with_payload``."""
        a = np.array(
            [
                self.I1 + self.m1 * self.r1**2 + self.m2 * self.l1**2,
                self.I2 + self.m2 * self.r2**2,
                self.m2 * self.l1 * self.r2,
                self.m1 * self.r1 + self.m2 * self.l1,
                self.m2 * self.r2,
            ]
        )
        if with_payload:
            a = a + self.payload * payload_increment(self.l1, self.l2)
        return a


PAPER_ARM = Planar2Params(payload=0.1)
"""The paper's arm: l = 0.5, m = 1.0, r = 0.2, I = 0.05, payload 0.1 kg, g = 9.8."""


def payload_increment(l1: float, l2: float) -> Array:
    return np.array([l1**2, l2**2, l1 * l2, l1, l2])


class Planar2Link:
    """The planar 2-link arm as an :class:`~calib.manipulator.model.ArmModel`."""

    def __init__(self, params: Planar2Params = PAPER_ARM, joint_names: tuple[str, ...] = ()):
        self.params = params
        self._names = joint_names or ("joint1", "joint2")

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def parameters(self) -> tuple[ParameterInfo, ...]:
        units = ("kg*m^2", "kg*m^2", "kg*m^2", "kg*m", "kg*m")
        return tuple(ParameterInfo(f"a{i + 1}", u) for i, u in enumerate(units))

    @property
    def nominal(self) -> Array:
        return self.params.theta()

    def payload_increment(self) -> Array:
        return payload_increment(self.params.l1, self.params.l2)

    # ---------------------------------------------------------------- regressors
    def regressor(self, q: Array, qd: Array, qdd: Array) -> Array:
        g = self.params.g
        c1, c2, c12 = np.cos(q[:, 0]), np.cos(q[:, 1]), np.cos(q[:, 0] + q[:, 1])
        s2 = np.sin(q[:, 1])
        d1, d2 = qd[:, 0], qd[:, 1]
        a1, a2 = qdd[:, 0], qdd[:, 1]
        Y = np.zeros((len(q), 2, 5))
        Y[:, 0, 0] = a1
        Y[:, 0, 1] = Y[:, 1, 1] = a1 + a2
        Y[:, 0, 2] = c2 * (2 * a1 + a2) - s2 * (2 * d1 * d2 + d2**2)
        Y[:, 1, 2] = c2 * a1 + s2 * d1**2
        Y[:, 0, 3] = g * c1
        Y[:, 0, 4] = Y[:, 1, 4] = g * c12
        return Y

    def momentum(self, q: Array, qd: Array) -> Array:
        c2 = np.cos(q[:, 1])
        d1, d2 = qd[:, 0], qd[:, 1]
        Y = np.zeros((len(q), 2, 5))
        Y[:, 0, 0] = d1
        Y[:, 0, 1] = Y[:, 1, 1] = d1 + d2
        Y[:, 0, 2] = c2 * (2 * d1 + d2)
        Y[:, 1, 2] = c2 * d1
        return Y

    def rest(self, q: Array, qd: Array) -> Array:
        g = self.params.g
        c1, c12 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1])
        s2 = np.sin(q[:, 1])
        d1, d2 = qd[:, 0], qd[:, 1]
        Y = np.zeros((len(q), 2, 5))
        Y[:, 1, 2] = s2 * (d1**2 + d1 * d2)  # -(C^T qd)_2 = -dT/dq2
        Y[:, 0, 3] = g * c1
        Y[:, 0, 4] = Y[:, 1, 4] = g * c12
        return Y

    # ---------------------------------------------------------------- dynamics (simulator)
    def mass_matrix(self, q: Array, theta: Array | None = None) -> Array:
        """(N, 2, 2) M(q) for ``theta`` (default: the model's own, payload included)."""
        a = self.nominal if theta is None else theta
        c2 = np.cos(q[:, 1])
        M = np.empty((len(q), 2, 2))
        M[:, 0, 0] = a[0] + a[1] + 2 * a[2] * c2
        M[:, 0, 1] = M[:, 1, 0] = a[1] + a[2] * c2
        M[:, 1, 1] = a[1]
        return M

    def bias(self, q: Array, qd: Array, theta: Array | None = None) -> Array:
        """(N, 2) C(q, qd) qd + tau_g(q)."""
        a = self.nominal if theta is None else theta
        return self.regressor(q, qd, np.zeros_like(qd)) @ a

    def points(self, q: Array) -> Array:
        l1, l2 = self.params.l1, self.params.l2
        out = np.zeros((len(q), 3, 3))
        out[:, 1, 0] = l1 * np.cos(q[:, 0])
        out[:, 1, 1] = l1 * np.sin(q[:, 0])
        out[:, 2, 0] = out[:, 1, 0] + l2 * np.cos(q[:, 0] + q[:, 1])
        out[:, 2, 1] = out[:, 1, 1] + l2 * np.sin(q[:, 0] + q[:, 1])
        return out
