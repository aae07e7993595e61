"""hitch_transient: the joint angle relaxes towards the steady state over a distance."""

from __future__ import annotations

from collections.abc import Mapping

from calib.tractor_trailer.discovery.effects.base import Effect, ParamSpec

__all__ = ["HitchTransient"]


class HitchTransient(Effect):
    """d psi/ds = [kappa (L2 + L1 cos psi) - sin psi] / lambda instead of the steady state.

    The off-axle trailer kinematics give lambda = L2: the joint angle lags the steady-state
    relation after every change of curvature and catches up over a few lambda of travel.
    """

    id = "hitch_transient"
    stage = 1
    sim_switch = "hitch_model"
    in_baselines = ("transient",)

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (
            ParamSpec("relaxation_length", "m", 2.0, 0.05, 30.0, 0.0, (0.5, 1.0, 3.0, 5.0, 10.0)),
        )

    @property
    def channels(self) -> tuple[str, ...]:
        return ("psi",)

    def relaxation_length(self, p: Mapping[str, float]) -> float | None:
        return p["relaxation_length"]

    def explanation(self, values: Mapping[str, float]) -> str:
        lam = values["relaxation_length"]
        return (
            "The joint angle does not follow the steady-state relation at once: after each "
            f"change of curvature it relaxes over about {lam:.2f} m of travel (off-axle trailer "
            "kinematics predict a relaxation length equal to L2), so it lags the command."
        )
