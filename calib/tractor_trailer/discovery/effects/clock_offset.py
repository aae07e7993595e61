"""clock_offset: one sensor topic's timestamps shifted against the others."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy.interpolate import CubicSpline

from calib.discovery import EffectKind
from calib.tractor_trailer.discovery.effects.base import (
    Effect,
    FloatArray,
    ParamSpec,
    SensorCorrections,
    remembered,
)

__all__ = ["ClockOffset"]

_CHANNEL = {"hitch": "psi", "odom": "omega"}
_STARTS = tuple(round(0.05 * i, 2) for i in range(-20, 21))


class ClockOffset(Effect):
    """A topic stamped ``offset`` seconds late: recorded(t) = true(t - offset).

    ``target`` is the sensor group: "hitch" (joint angle) or "odom" (speed and yaw rate; the
    speed input is moved back onto the true clock too). Rule against ``actuator_delay``: a
    clock offset moves one topic only (the other output still lines up with the command);
    a delay moves yaw rate and joint angle together relative to the command.
    """

    id = "clock_offset"
    stage = 2
    order = 0
    kind = EffectKind.CLOCK
    confounded_with = ("actuator_delay",)
    sim_switch = "clock_offset_s"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("offset", "s", 0.0, -2.0, 2.0, 0.0, _STARTS, time_shift=True),)

    @property
    def channels(self) -> tuple[str, ...]:
        return (_CHANNEL[self.target or "hitch"],)

    @property
    def changes_inputs(self) -> bool:
        return self.target == "odom"  # the speed comes with the odometry

    def modify_inputs(
        self, t_s: FloatArray, kappa: FloatArray, v: FloatArray, p: Mapping[str, float]
    ) -> tuple[FloatArray, FloatArray]:
        if self.target != "odom":
            return kappa, v
        c = p["offset"]
        return kappa, remembered(self, ("v", c), (t_s, v), lambda: np.interp(t_s + c, t_s, v))

    def modify_output(
        self, name: str, t_s: FloatArray, y: FloatArray, p: Mapping[str, float]
    ) -> FloatArray:
        if name != _CHANNEL[self.target or "hitch"]:
            return y
        # the joint angle is continuous: a spline keeps the fit smooth in the offset; the yaw
        # rate jumps with step commands, where a spline would ring: linear there, across jumps
        # too (a jump held at a row would give the offset a zero gradient; a one-row ramp is
        # what the recorded, interpolated yaw rate shows anyway)
        c = p["offset"]
        if name == "psi":  # base.shift(smooth=True), the spline kept for the next offset
            spline = remembered(self, "spline", (t_s, y), lambda: CubicSpline(t_s, y))
            tq = np.clip(t_s - c, t_s[0], t_s[-1])
            return remembered(self, c, (t_s, y), lambda: np.asarray(spline(tq), dtype=float))
        return remembered(self, c, (t_s, y), lambda: np.interp(t_s - c, t_s, y))

    def joint_angle_correction(self, p: Mapping[str, float]) -> SensorCorrections | None:
        """On the joint-angle topic: its stamps late by the offset."""
        if _CHANNEL[self.target or "hitch"] != "psi":
            return None
        return SensorCorrections(psi_shift_s=float(p["offset"]), labels=(self.key,))

    def explanation(self, values: Mapping[str, float]) -> str:
        topic = "joint-angle" if self.target == "hitch" else "odometry (speed, yaw rate)"
        c = values["offset"]
        when = "late" if c >= 0 else "early"
        return (
            f"The {topic} topic is stamped {abs(c):.3f} s {when} against the command and the "
            "other sensors (unsynchronised clocks or a buffering delay in that driver): only "
            "this signal is shifted in time, the others still line up with the command."
        )
