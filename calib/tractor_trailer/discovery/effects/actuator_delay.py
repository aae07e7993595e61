"""actuator_delay: dead time between the curvature command and the motion."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from calib.tractor_trailer.discovery.effects.actuator_lag import ActuatorLag
from calib.tractor_trailer.discovery.effects.base import Effect, Equivalent, ParamSpec, Values
from calib.tractor_trailer.discovery.effects.clock_offset import ClockOffset

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

    def equivalents(self, channels: tuple[str, ...]) -> tuple[Equivalent, ...]:
        """The same clock offset on every measured topic (odometry for the yaw rate, hitch for
        the joint angle): delay = offset, a dead time from their mean (at least 0); a
        first-order lag of time constant = delay (at least 1 ms)."""
        me = self.key
        clocks = tuple(
            c.key
            for c in (ClockOffset("odom"), ClockOffset("hitch"))
            if set(c.channels) & set(channels)
        )
        lag = ActuatorLag().key

        def to_clocks(v: Values, data: object) -> dict[str, dict[str, float]]:
            return {k: {"offset": v[me]["delay"]} for k in clocks}

        def from_clocks(v: Values, data: object) -> dict[str, dict[str, float]]:
            offsets = [v[k]["offset"] for k in clocks if k in v]
            return {me: {"delay": max(float(np.mean(offsets)), 0.0)}}

        def to_lag(v: Values, data: object) -> dict[str, dict[str, float]]:
            return {lag: {"time_constant": max(v[me]["delay"], 1e-3)}}

        def from_lag(v: Values, data: object) -> dict[str, dict[str, float]]:
            return {me: {"delay": v[lag]["time_constant"]}}

        return (
            Equivalent(
                "dead_time_vs_clock_offsets",
                "an actuator dead time delays the yaw rate and the joint angle against the "
                "command exactly as the same clock offset on every measured topic would; they "
                "differ only through speed changes within the delay",
                (me,),
                clocks,
                to_clocks,
                from_clocks,
                agree="offset",
                agree_note="the clock offsets agree with each other: one shift of every "
                "measured topic, which is what a dead time looks like",
            ),
            Equivalent(
                "dead_time_vs_lag",
                "a first-order steering lag of time constant tau delays slow commands like a "
                "dead time tau; only fast command changes (steps) tell them apart",
                (me,),
                (lag,),
                to_lag,
                from_lag,
                exact=False,
            ),
        )

    def explanation(self, values: Mapping[str, float]) -> str:
        return (
            f"The vehicle starts to follow a curvature command {values['delay']:.3f} s after it "
            "is sent (dead time in the steering actuator or its controller): yaw rate and joint "
            "angle lag the command together. A command topic stamped late by the same amount "
            "would look the same."
        )
