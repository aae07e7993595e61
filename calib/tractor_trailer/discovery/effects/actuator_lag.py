"""actuator_lag: first-order lag between commanded and actual curvature."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from calib.tractor_trailer.discovery.effects.base import Effect, FloatArray, ParamSpec, remembered
from calib.tractor_trailer.models.hitch_rk4 import lag_recursion

__all__ = ["ActuatorLag", "first_order_lag"]

_STARTS = (0.02, 0.05, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


def first_order_lag(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """Exact solution of tau dy/dt = x - y, y(t_0) = x(t_0), for ``x`` linear between its
    samples at ``t_s`` (s; any spacing).

    Per step h: y_k+1 = a y_k + (1 - c) x_k+1 + (c - a) x_k, a = exp(-h / tau),
    c = (tau / h)(1 - a). A trapezoidal hold ((1 - a) / 2 on both samples) is only right for
    h << tau: with a lag of a few grid steps it smears the response like a longer lag and a
    dead time fits the log better than the lag that made it. The recursion is sequential and
    runs in the compiled loop of ``calib.tractor_trailer.models.hitch_rk4`` (it is stable: 0 <= a
    <= 1).
    """
    if tau_s <= 0 or x.size < 2:
        return x
    h = np.diff(t_s)
    r = np.where(h > 0, h, 0.0) / tau_s
    one_minus_a = -np.expm1(-r)
    a = 1.0 - one_minus_a
    # c -> 1 as h -> 0 (1 - a ~ h / tau): a zero step changes nothing
    c = np.where(r > 1e-8, one_minus_a / np.where(r > 1e-8, r, 1.0), 1.0 - 0.5 * r)
    u = (1.0 - c) * x[1:] + (c - a) * x[:-1]
    return lag_recursion(a, u, float(x[0]))


class ActuatorLag(Effect):
    """tau d kappa/dt = kappa_cmd - kappa: the steering reaches the command gradually."""

    id = "actuator_lag"
    stage = 0
    order = 2
    confounded_with = ("actuator_delay",)
    sim_switch = "actuator_lag_s"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        # a timing parameter: on step commands it is known no better than the jumps' times
        return (ParamSpec("time_constant", "s", 0.1, 0.001, 5.0, 0.0, _STARTS, time_shift=True),)

    @property
    def channels(self) -> tuple[str, ...]:
        return ("omega", "psi")

    def modify_inputs(
        self, t_s: FloatArray, kappa: FloatArray, v: FloatArray, p: Mapping[str, float]
    ) -> tuple[FloatArray, FloatArray]:
        tau = p["time_constant"]
        # the curvature alone is lagged: a fit moving the speed or the lengths reuses it
        lagged = remembered(self, tau, (t_s, kappa), lambda: first_order_lag(t_s, kappa, tau))
        return lagged, v

    def explanation(self, values: Mapping[str, float]) -> str:
        return (
            "The steering does not jump to a new curvature command but approaches it "
            f"exponentially with time constant {values['time_constant']:.3f} s (a first-order "
            "lag: actuator bandwidth or steering-rate limit)."
        )
