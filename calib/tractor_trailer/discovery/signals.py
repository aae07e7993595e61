"""Input signals on the fitting grid: command, speed and their derivatives (for diagnostics)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from calib.tractor_trailer.discovery.data import DiscoveryData, block_mean
from calib.tractor_trailer.discovery.effects.base import shift

__all__ = ["INPUT_UNITS", "delayed", "input_signals"]

FloatArray = NDArray[np.float64]

INPUT_UNITS: dict[str, str] = {
    "kappa_cmd": "1/m",
    "dkappa_cmd/dt": "1/(m s)",
    "dkappa_cmd/ds": "1/m^2",
    "v": "m/s",
    "dv/dt": "m/s^2",
    "v*kappa_cmd": "rad/s",
    "v^2*kappa_cmd": "m/s^2",
}


def input_signals(data: DiscoveryData) -> dict[str, FloatArray]:
    """Inputs on the fitting grid: kappa_cmd (1/m), its rate per time and per distance, speed,
    acceleration, commanded yaw rate v kappa_cmd and lateral acceleration v^2 kappa_cmd."""
    t = data.tc_s
    k = block_mean(data.kappa_cmd, data.m)
    v = block_mean(data.v, data.m)
    dk = np.gradient(k, t)
    speed = np.maximum(np.abs(v), 0.1)
    return {
        "kappa_cmd": k,
        "dkappa_cmd/dt": dk,
        "dkappa_cmd/ds": dk / speed,
        "v": v,
        "dv/dt": np.gradient(v, t),
        "v*kappa_cmd": v * k,
        "v^2*kappa_cmd": v * v * k,
    }


def delayed(data: DiscoveryData, x: FloatArray, delay_s: float) -> FloatArray:
    """``x`` (on the fitting grid) delayed by ``delay_s`` seconds."""
    return shift(data.tc_s, x, delay_s)
