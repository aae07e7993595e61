"""sensor_scale: a gain error on a measured signal."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import (
    PARAM,
    Effect,
    Equivalent,
    FloatArray,
    ParamSpec,
    SensorCorrections,
)

__all__ = ["MAX_SPAN", "SensorScale"]

MAX_SPAN = 0.1
"""A joint-angle gain the log does not pin is spanned (the link lengths refitted at the ends of
its interval) only when that interval lies within 1 +/- this; wider, the link lengths are not
determined by the log."""


class SensorScale(Effect):
    """recorded = scale * true, for one output (``target`` "psi" or "omega")."""

    id = "sensor_scale"
    stage = 2
    order = 1
    sim_switch = "sensor_scale"

    @property
    def confounded_with(self) -> tuple[str, ...]:  # type: ignore[override]
        return (f"{PARAM}L1", f"{PARAM}L2") if self.target == "psi" else ("understeer",)

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

    def equivalents(self, channels: tuple[str, ...]) -> tuple[Equivalent, ...]:
        """A joint-angle gain against the link lengths: at small angles psi ~ kappa (L1 + L2),
        so L1 + L2 take a gain in (the log fixes only their product)."""
        if self.target != "psi" or "psi" not in channels:
            return ()
        return (
            Equivalent(
                "joint_angle_gain_vs_link_lengths",
                "a gain of the joint-angle sensor is taken in by L1 + L2 (psi ~ kappa (L1 + L2) "
                "at small angles)",
                (self.key,),
                (f"{PARAM}L1", f"{PARAM}L2"),
                what="the joint-angle sensor's gain",
                assumes="a gain of exactly 1",
                span_within=MAX_SPAN,
            ),
        )

    def joint_angle_correction(self, p: Mapping[str, float]) -> SensorCorrections | None:
        """On the joint angle: recorded = scale x true (a positive scale only)."""
        if self.target != "psi" or not p["scale"] > 0:
            return None
        return SensorCorrections(psi_scale=float(p["scale"]), labels=(self.key,))

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
