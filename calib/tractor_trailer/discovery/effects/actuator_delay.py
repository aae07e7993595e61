"""actuator_delay: dead time between the curvature command and the motion."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import Effect, ParamSpec

__all__ = ["ActuatorDelay"]

_STARTS = tuple(round(0.05 * i, 2) for i in range(21))


class ActuatorDelay(Effect):
    """kappa_actual(t) = kappa_cmd(t - delay): yaw rate and joint angle both lag the command."""

    id = "actuator_delay"
    stage = 0
    order = 1
    confounded_with = ("clock_offset(odom)", "clock_offset(hitch)", "actuator_lag")
    sim_switch = "actuator_delay_s"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("delay", "s", 0.05, 0.0, 2.0, 0.0, _STARTS, time_shift=True),)

    @property
    def channels(self) -> tuple[str, ...]:
        return ("omega", "psi")

    def input_delay(self, p: Mapping[str, float]) -> float:
        return p["delay"]

    def explanation(self, values: Mapping[str, float]) -> str:
        return (
            f"The vehicle starts to follow a curvature command {values['delay']:.3f} s after it "
            "is sent (dead time in the steering actuator or its controller): yaw rate and joint "
            "angle lag the command together. A command topic stamped late by the same amount "
            "would look the same."
        )
