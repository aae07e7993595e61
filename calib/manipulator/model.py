"""What every arm model provides to the identification: the rigid-body regressor in its three
forms, the joints, forward-kinematics points for drawing, and the regressor increment of a held
payload.

The three forms share one parameter vector ``theta`` (length ``p``):

* ``regressor(q, qd, qdd)``: the classic one, ``tau = Y theta`` (needs the joint acceleration);
* ``momentum(q, qd)``: the generalised momentum ``p = M(q) qd = Y_p theta``;
* ``rest(q, qd)``: the rest of the momentum equation, ``-(C^T qd - tau_g) = Y_r theta``, so that
  ``tau = d/dt(Y_p theta) + Y_r theta`` and, integrated over a window,
  ``int tau dt = [Y_p]_a^b theta + int Y_r dt theta`` with no acceleration anywhere.

Arrays: ``q``, ``qd``, ``qdd`` are (N, n); regressors are (N, n, p).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from calib.errors import CalibError

__all__ = ["ArmModel", "ArmModelError", "ParameterInfo"]

Array = NDArray[np.float64]


class ArmModelError(CalibError):
    """An arm model that cannot be built (URDF not found or unreadable, joints not in it)."""


@dataclass(frozen=True)
class ParameterInfo:
    """Name and unit of one rigid-body parameter (``kg``, ``kg*m``, ``kg*m^2``)."""

    name: str
    unit: str


class ArmModel(Protocol):
    """A serial arm whose dynamics are linear in ``theta`` (see the module docstring)."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def parameters(self) -> tuple[ParameterInfo, ...]: ...

    @property
    def nominal(self) -> Array | None:
        """The model's own parameter values (URDF, design), or None."""
        ...

    def regressor(self, q: Array, qd: Array, qdd: Array) -> Array: ...

    def momentum(self, q: Array, qd: Array) -> Array: ...

    def rest(self, q: Array, qd: Array) -> Array: ...

    def payload_increment(self) -> Array:
        """``delta theta`` of a 1 kg point mass at the tool point (theta grows by M * this)."""
        ...

    def points(self, q: Array) -> Array:
        """(N, k, 3) positions of the base, each joint and the tool point, for drawing (m)."""
        ...
