"""sensor_scale: a gain error on a measured signal."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import Effect, FloatArray, ParamSpec

__all__ = ["SensorScale"]


class SensorScale(Effect):
    """recorded = scale * true, for one output (``target`` "psi" or "omega")."""

    id = "sensor_scale"
    stage = 2
    order = 1
    sim_switch = "sensor_scale"

    @property
    def confounded_with(self) -> tuple[str, ...]:  # type: ignore[override]
        return ("param:L1", "param:L2") if self.target == "psi" else ("understeer",)

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("scale", "", 1.0, 0.5, 2.0, 1.0),)

    @property
    def channels(self) -> tuple[str, ...]:
        return (self.target or "omega",)

    def modify_output(
        self, name: str, t_s: FloatArray, y: FloatArray, p: Mapping[str, float]
    ) -> FloatArray:
        return y * p["scale"] if name == self.target else y

    def true_from_recorded(self, name: str, y: float, p: Mapping[str, float]) -> float:
        return y / p["scale"] if name == self.target and p["scale"] != 0 else y

    def explanation(self, values: Mapping[str, float]) -> str:
        what = "joint-angle sensor" if self.target == "psi" else "yaw-rate sensor"
        pct = 100.0 * (values["scale"] - 1.0)
        note = (
            " A joint-angle gain trades off against the link lengths; trust it only with large"
            " angles or transients in the log."
            if self.target == "psi"
            else ""
        )
        return (
            f"The {what} reads {pct:+.2f} % of the true value (gain {values['scale']:.4f}), "
            f"e.g. a wrong calibration constant.{note}"
        )
