"""actuator_lag: first-order lag between commanded and actual curvature."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from calib.discovery.effects.base import Effect, FloatArray, ParamSpec

__all__ = ["ActuatorLag", "first_order_lag"]

_STARTS = (0.02, 0.05, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


def first_order_lag(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """Exact solution of tau dy/dt = x - y, y(t_0) = x(t_0), for ``x`` linear between its
    samples at ``t_s`` (s; any spacing).

    Per step h: y_k+1 = a y_k + (1 - c) x_k+1 + (c - a) x_k, a = exp(-h / tau),
    c = (tau / h)(1 - a). A trapezoidal hold ((1 - a) / 2 on both samples) is only right for
    h << tau: with a lag of a few grid steps it smears the response like a longer lag and a
    dead time fits the log better than the lag that made it. The linear recursion is summed in
    closed form (y_k = A_k (y_0 + sum_j u_j / A_j+1), A the running product of a) in chunks
    over which A falls by at most exp(-``_CHUNK_DECAY``), so nothing under- or overflows.
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
    logs = np.concatenate([[0.0], -np.cumsum(r)])  # log A_k, k = 0..n-1
    y = np.empty_like(x, dtype=float)
    y[0] = x[0]
    start = 0
    n = x.size
    while start < n - 1:
        end = int(np.searchsorted(-logs, -logs[start] + _CHUNK_DECAY, side="right"))
        if end <= start + 1:  # one step longer than the chunk's decay: the recursion itself
            y[start + 1] = a[start] * y[start] + u[start]
            start += 1
            continue
        end = min(end, n)  # samples start..end-1 of this chunk
        rel = logs[start:end] - logs[start]  # log A relative to the chunk start, 0 .. -decay
        w = np.exp(-rel[1:])  # 1 / A_j+1
        acc = y[start] + np.cumsum(u[start : end - 1] * w)
        y[start + 1 : end] = np.exp(rel[1:]) * acc
        start = end - 1
    return y


_CHUNK_DECAY = 500.0


class ActuatorLag(Effect):
    """tau d kappa/dt = kappa_cmd - kappa: the steering reaches the command gradually."""

    id = "actuator_lag"
    stage = 0
    order = 2

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
        return first_order_lag(t_s, kappa, p["time_constant"]), v

    def explanation(self, values: Mapping[str, float]) -> str:
        return (
            "The steering does not jump to a new curvature command but approaches it "
            f"exponentially with time constant {values['time_constant']:.3f} s (a first-order "
            "lag: actuator bandwidth or steering-rate limit)."
        )
