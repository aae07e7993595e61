"""The odometry + IMU catalogue: effects on the yaw-rate gain G = odometry yaw rate / gyro yaw
rate. Each effect's hook (a :class:`GainEffectModel`) says what it adds to the gain
G = (1 + sum of constant parts) (1 + sum of growth parts); the fitter never reads an id.

* ``effective_track``: a constant gain (skid steer: effective track = geometric track x G);
* ``turn_slip``: G grows with |turn rate| (the wheels slide more the faster the robot turns);
* ``speed_slip``: G grows with speed;
* ``icr_slip``: skid-steer slip depending jointly on speed and turn rate, the tracks'
  instantaneous centres of rotation (ICRs) moving outwards (below).

**The ICR model** (in the line of Mandow et al. 2007, "Experimental kinematics for wheeled
skid-steer mobile robots", IROS): a skid steer's kinematics are a differential drive's with each
side's wheel contact replaced by the instantaneous centre of rotation (ICR) of that side's
tread, at lateral positions y_L and y_R in the body frame; the body yaw rate is
omega = (v_R - v_L) / (y_L - y_R) and, with ICRs symmetric about the centre line
(y_L = -y_R), the forward speed is (v_R + v_L) / 2 as the odometry says. The odometry divides
the same wheel speed difference by the geometric track b, so the yaw-rate gain is
G = (y_L - y_R) / b = b_eff / b, and the gyro sees the odometry's turn times b / b_eff.
Mandow et al. found the ICRs fixed for a given vehicle and floor at moderate speeds; they move
outwards as the treads slip more, and the slip grows with the forces the tyres must supply
sideways: the scrub that resists turning (growing with the turn rate) and the centripetal force
(growing with v |omega|). Written as the share of the turn lost,
b / b_eff = (1 / G0) (1 - a |omega| - c |v| |omega|), i.e.
b_eff = b G0 / (1 - a |omega| - c |v| |omega|), G0 the gain of a slow turn: the effect holds
all three (the ICRs' spacing and their motion are one model; ``effective_track`` is its
special case a = c = 0, so the two are never fitted together). The slip form is linear in a
and c (a share of the turn that reaches all of it where the robot stops turning, with no pole in
the fit), and to first order it is the growth b_eff = b G0 (1 + a |omega| + c |v| |omega|). The
covariates are the odometry's own speed and turn rate (what the wheels do, from which the slip
follows); a log without ground truth sees only the yaw-rate gain, not the ICRs' longitudinal
offset.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.windows import Windows
from calib.discovery import EffectKind, EffectParam, EffectSpec

__all__ = [
    "GAIN",
    "ICR_SLIP",
    "SPEED_SLIP",
    "TURN_SLIP",
    "Constant",
    "GainEffectModel",
    "GainOnly",
    "Growth",
    "IcrSlip",
]

Array = NDArray[np.float64]


class GainEffectModel(Protocol):
    """How one effect changes the yaw-rate gain: the hook of its
    :class:`~calib.adequacy.EffectSpec` (``values``: its own parameters by name)."""

    @property
    def covers(self) -> tuple[str, ...]:
        """The parts of the gain it fits ("1": the constant; "rate", "speed", "speed*rate": a
        growth with that covariate): two effects that fit one part are one effect twice
        (nested), not a model."""
        ...

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        """What it adds to G's constant part and to its growth part on windows ``rows``."""
        ...

    @property
    def form(self) -> str:
        """Where its parameters enter: "constant" (G0), "growth" (G's growth part) or "slip"
        (the fraction of the turn lost), for the law's formula."""
        ...

    def slip(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        """The fraction of the odometry's turn it loses on windows ``rows``: the gyro sees
        odometry x (1 - sum of slips) / G."""
        ...

    def added_yaw(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        """What it adds to the gyro's yaw change on windows ``rows`` (rad), besides the gain."""
        ...


class GainOnly:
    """Defaults of a :class:`GainEffectModel` that changes only the gain: no slip, no added
    yaw (an effect overrides what it changes)."""

    def slip(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        return 0.0

    def added_yaw(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        return 0.0


@dataclass(frozen=True)
class Constant(GainOnly):
    param: str
    covers: tuple[str, ...] = ("1",)
    form: str = "constant"

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        return values[self.param], 0.0


@dataclass(frozen=True)
class Growth(GainOnly):
    param: str
    covariate: str
    """The :class:`Windows` field the gain grows with."""

    form: str = "growth"

    @property
    def covers(self) -> tuple[str, ...]:
        return (self.covariate,)

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        x: Array = getattr(w, self.covariate)[rows]
        return 0.0, values[self.param] * x


@dataclass(frozen=True)
class IcrSlip(GainOnly):
    """The ICR model: the treads' ICRs G0 b apart in a slow turn (``rest``: G0 - 1, the constant
    part) and the share a |omega| + c |v| |omega| of the turn lost as they move outwards (module
    docstring)."""

    rest: str
    turn: str
    joint: str
    covers: tuple[str, ...] = ("1", "rate", "speed*rate")
    form: str = "slip"

    def gain(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> tuple[float | Array, float | Array]:
        return values[self.rest], 0.0

    def slip(
        self, values: Mapping[str, float], w: Windows, rows: NDArray[np.intp]
    ) -> float | Array:
        rate, speed = w.rate[rows], w.speed[rows]
        out: Array = values[self.turn] * rate + values[self.joint] * speed * rate
        return out


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
ICR_SLIP: EffectSpec[GainEffectModel] = EffectSpec(
    "icr_slip",
    "track",
    EffectKind.DYNAMICS,
    (
        EffectParam("gain_minus_1", "1", 0.0, -0.9, 20.0, 0.0),
        EffectParam("per_rad_s", "s/rad", 0.0, -5.0, 5.0, 0.0),
        EffectParam("per_m_rad", "s^2/(m rad)", 0.0, -5.0, 5.0, 0.0),
    ),
    "skid-steer slip: the treads' centres of rotation move outwards as the turn rate and the "
    "centripetal acceleration grow, so the robot loses a share of its turn that depends "
    "jointly on speed and turn rate (b_eff = b G0 / (1 - a |omega| - c |v| |omega|), the ICR "
    "model of Mandow et al. 2007)",
    confounded_with=("effective_track(track)", "turn_slip(track)", "speed_slip(track)"),
    sim_switch="icr_turn, icr_joint (calib.diff_drive.sim.OdomImuSimConfig)",
    model=IcrSlip("gain_minus_1", "per_rad_s", "per_m_rad"),
)
