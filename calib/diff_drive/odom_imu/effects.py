"""The odometry + IMU catalogue: effects on the yaw-rate gain G = odometry yaw rate / gyro yaw
rate. Each effect's hook (a :class:`GainEffectModel`) says what it adds to the gain
G = (1 + sum of constant parts) (1 + sum of growth parts); the fitter never reads an id.

* ``effective_track``: a constant gain (skid steer: effective track = geometric track x G);
* ``turn_slip``: G grows with |turn rate| (the wheels slide more the faster the robot turns);
* ``speed_slip``: G grows with speed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.windows import Windows
from calib.discovery import EffectKind, EffectParam, EffectSpec

__all__ = ["GAIN", "SPEED_SLIP", "TURN_SLIP", "Constant", "GainEffectModel", "Growth"]

Array = NDArray[np.float64]


class GainEffectModel(Protocol):
    """How one effect changes the yaw-rate gain: the hook of its
    :class:`~calib.adequacy.EffectSpec` (``values``: its own parameters by name)."""

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        """What it adds to G's constant part and to its growth part on windows ``rows``."""
        ...


@dataclass(frozen=True)
class Constant:
    param: str

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        return values[self.param], 0.0


@dataclass(frozen=True)
class Growth:
    param: str
    covariate: str
    """The :class:`Windows` field the gain grows with."""

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        x: Array = getattr(w, self.covariate)[rows]
        return 0.0, values[self.param] * x


TURN_SLIP: EffectSpec[GainEffectModel] = EffectSpec(
    "turn_slip",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("per_rad_s", "s/rad", 0.0, -0.9, 20.0, 0.0),),
    "the wheels slide more the faster the robot turns: the yaw-rate gain grows with |turn "
    "rate| (G = G0 (1 + s |omega|))",
    confounded_with=("speed_slip(track)",),
    model=Growth("per_rad_s", "rate"),
)
SPEED_SLIP: EffectSpec[GainEffectModel] = EffectSpec(
    "speed_slip",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("per_m_s", "s/m", 0.0, -0.9, 20.0, 0.0),),
    "the yaw-rate gain grows with speed (G = G0 (1 + s |v|))",
    confounded_with=("turn_slip(track)",),
    model=Growth("per_m_s", "speed"),
)
GAIN: EffectSpec[GainEffectModel] = EffectSpec(
    "effective_track",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("gain_minus_1", "1", 0.0, -0.9, 20.0, 0.0),),
    "the robot turns slower than its wheel odometry says (skid steer: effective track = "
    "geometric track x gain)",
    model=Constant("gain_minus_1"),
)
