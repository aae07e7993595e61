"""understeer: curvature falls with speed."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from calib.tractor_trailer.discovery.effects.base import (
    Effect,
    Equivalent,
    FloatArray,
    ParamSpec,
    Values,
)
from calib.tractor_trailer.discovery.effects.sensor_scale import SensorScale

if TYPE_CHECKING:
    from calib.tractor_trailer.discovery.data import DiscoveryData

__all__ = ["Understeer"]


class Understeer(Effect):
    """kappa = kappa_cmd / (1 + K v^2), K in s^2/m^2 (negative K: oversteer)."""

    id = "understeer"
    stage = 0
    order = 3
    confounded_with = ("sensor_scale(omega)",)
    sim_switch = "understeer_K"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("K", "s^2/m^2", 0.0, -0.2, 2.0, 0.0),)

    @property
    def channels(self) -> tuple[str, ...]:
        return ("omega", "psi")

    def modify_inputs(
        self, t_s: FloatArray, kappa: FloatArray, v: FloatArray, p: Mapping[str, float]
    ) -> tuple[FloatArray, FloatArray]:
        return kappa / (1.0 + p["K"] * v * v), v

    def equivalents(self, channels: tuple[str, ...]) -> tuple[Equivalent, ...]:
        """A gain of the yaw rate (recorded): at the log's mean v^2, scale = 1 / (1 + K v^2)."""
        if "omega" not in channels:
            return ()
        me, gain = self.key, SensorScale("omega").key

        def v2(data: DiscoveryData) -> float:
            return max(data.mean_square_speed(), 1e-6)

        def to_gain(v: Values, data: DiscoveryData) -> dict[str, dict[str, float]]:
            return {gain: {"scale": 1.0 / (1.0 + v[me]["K"] * v2(data))}}

        def from_gain(v: Values, data: DiscoveryData) -> dict[str, dict[str, float]]:
            return {me: {"K": (1.0 / v[gain]["scale"] - 1.0) / v2(data)}}

        return (
            Equivalent(
                "understeer_vs_yaw_rate_gain",
                "at constant speed understeer scales the curvature by 1 / (1 + K v^2): the yaw "
                "rate shows it as a gain error and the joint angle as slightly different link "
                "lengths; only speed changes tell them apart",
                (me,),
                (gain,),
                to_gain,
                from_gain,
            ),
        )

    def explanation(self, values: Mapping[str, float]) -> str:
        k = values["K"]
        word = "understeers" if k >= 0 else "oversteers"
        return (
            f"The vehicle {word}: the curvature it drives falls short of the command as speed "
            f"grows, kappa = kappa_cmd / (1 + K v^2) with K = {k:.4g} s^2/m^2 (tyre slip "
            f"angles), i.e. {100 * k / (1 + k):.1f} % less curvature at 1 m/s."
        )
