"""Input effects of the arm's catalogue: the torque the model sees is the logged torque moved
in time (a delay) or through a first-order lag."""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from calib.manipulator.discovery.hooks import Array, FitterView, InputEffect

__all__ = ["DelayInput", "LagInput"]


class DelayInput(InputEffect):
    """The torque acting at t was logged at t - d."""

    def acting(self, fitter: FitterView, p: float) -> Array:
        s = fitter.sig
        return np.stack(
            [np.interp(s.t_s - p, s.t_s, s.tau_f[:, j]) for j in range(fitter.n)], axis=1
        )

    def logged(self, fitter: FitterView, p: float, pred: Array) -> Array:
        t = fitter.sig.t_s
        return np.stack([np.interp(t + p, t, pred[:, j]) for j in range(fitter.n)], axis=1)


class LagInput(InputEffect):
    """The torque acts through a first-order lag of time constant T."""

    def acting(self, fitter: FitterView, p: float) -> Array:
        s = fitter.sig
        a = math.exp(-(1.0 / s.rate_hz) / p) if p > 0 else 0.0
        zi = a * s.tau_f[0]
        out, _ = lfilter([1.0 - a], [1.0, -a], s.tau_f, axis=0, zi=zi[None, :])
        return np.asarray(out, dtype=float)

    def logged(self, fitter: FitterView, p: float, pred: Array) -> Array:
        out: Array = pred + p * np.gradient(pred, fitter.sig.t_s, axis=0)
        return out
