"""sensor_offset: a constant bias on a measured signal."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import (
    Effect,
    FloatArray,
    ParamSpec,
    SensorCorrections,
)

__all__ = ["SensorOffset"]

_UNITS = {"psi": "rad", "omega": "rad/s"}


class SensorOffset(Effect):
    """recorded = true + offset, for one output (``target`` "psi" or "omega")."""

    id = "sensor_offset"
    stage = 2
    order = 2
    sim_switch = "sensor_offset"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("offset", _UNITS[self.target or "psi"], 0.0, -0.5, 0.5, 0.0),)

    @property
    def channels(self) -> tuple[str, ...]:
        return (self.target or "psi",)

    def modify_output(
        self, name: str, t_s: FloatArray, y: FloatArray, p: Mapping[str, float]
    ) -> FloatArray:
        return y + p["offset"] if name == self.target else y

    def true_from_recorded(self, name: str, y: float, p: Mapping[str, float]) -> float:
        return y - p["offset"] if name == self.target else y

    def joint_angle_correction(self, p: Mapping[str, float]) -> SensorCorrections | None:
        """On the joint angle: a constant offset the path fit fits itself."""
        if self.target != "psi":
            return None
        return SensorCorrections(psi_offset=True, labels=(self.key,))

    def explanation(self, values: Mapping[str, float]) -> str:
        what = "joint-angle sensor" if self.target == "psi" else "yaw-rate sensor"
        unit = _UNITS[self.target or "psi"]
        return (
            f"The {what} reads {values['offset']:+.4g} {unit} off at all times (a constant "
            "bias, e.g. a mis-zeroed encoder or gyro), which the baseline takes for physics."
        )
