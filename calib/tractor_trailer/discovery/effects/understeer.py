"""understeer: curvature falls with speed."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import Effect, FloatArray, ParamSpec

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

    def explanation(self, values: Mapping[str, float]) -> str:
        k = values["K"]
        word = "understeers" if k >= 0 else "oversteers"
        return (
            f"The vehicle {word}: the curvature it drives falls short of the command as speed "
            f"grows, kappa = kappa_cmd / (1 + K v^2) with K = {k:.4g} s^2/m^2 (tyre slip "
            f"angles), i.e. {100 * k / (1 + k):.1f} % less curvature at 1 m/s."
        )
