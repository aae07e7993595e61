"""actuator_lag: first-order lag between commanded and actual curvature."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy.signal import lfilter

from calib.discovery.effects.base import Effect, FloatArray, ParamSpec

__all__ = ["ActuatorLag", "first_order_lag"]

_STARTS = (0.02, 0.05, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


def first_order_lag(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """Output of tau dy/dt = x - y on a uniform grid (trapezoidal input hold), y(0) = x(0)."""
    if tau_s <= 0 or x.size < 2:
        return x
    dt = float(np.median(np.diff(t_s)))
    a = float(np.exp(-dt / tau_s))
    b = np.array([(1.0 - a) / 2.0, (1.0 - a) / 2.0])
    zi = np.array([x[0] * a - b[1] * x[0]])
    y, _ = lfilter(b, np.array([1.0, -a]), x, zi=zi)
    return np.asarray(y, dtype=float)


class ActuatorLag(Effect):
    """tau d kappa/dt = kappa_cmd - kappa: the steering reaches the command gradually."""

    id = "actuator_lag"
    stage = 0
    order = 2

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        return (ParamSpec("time_constant", "s", 0.1, 0.001, 5.0, 0.0, _STARTS),)

    @property
    def channels(self) -> tuple[str, ...]:
        return ("omega", "psi")

    def modify_inputs(
        self, t_s: FloatArray, kappa: FloatArray, v: FloatArray, p: Mapping[str, float]
    ) -> tuple[FloatArray, FloatArray]:
        return first_order_lag(t_s, kappa, p["time_constant"]), v

    def explanation(self, values: Mapping[str, float]) -> str:
        return (
            "The steering does not jump to a new curvature command but approaches it "
            f"exponentially with time constant {values['time_constant']:.3f} s (a first-order "
            "lag: actuator bandwidth or steering-rate limit)."
        )
