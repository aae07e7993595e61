"""The catalogue of physical effects: one interface (``Effect``), one module per effect.

To add an effect, subclass ``Effect`` in a new module and list an instance in ``catalogue``.
"""

from __future__ import annotations

from typing import Literal

from calib.tractor_trailer.discovery.effects.actuator_delay import ActuatorDelay
from calib.tractor_trailer.discovery.effects.actuator_lag import ActuatorLag
from calib.tractor_trailer.discovery.effects.base import Effect, ParamSpec
from calib.tractor_trailer.discovery.effects.clock_offset import ClockOffset
from calib.tractor_trailer.discovery.effects.hitch_transient import HitchTransient
from calib.tractor_trailer.discovery.effects.sensor_offset import SensorOffset
from calib.tractor_trailer.discovery.effects.sensor_scale import SensorScale
from calib.tractor_trailer.discovery.effects.understeer import Understeer

__all__ = [
    "ActuatorDelay",
    "ActuatorLag",
    "ClockOffset",
    "Effect",
    "HitchTransient",
    "ParamSpec",
    "SensorOffset",
    "SensorScale",
    "Understeer",
    "catalogue",
]


def catalogue(
    baseline: Literal["steady", "transient"] = "steady",
    channels: tuple[str, ...] = ("omega", "psi"),
) -> list[Effect]:
    """Candidate effects of the tractor-trailer for ``baseline`` and the recorded ``channels``.

    ``hitch_transient`` is a candidate only against the steady-state baseline (the transient
    baseline already contains it); effects on a channel that was not recorded are left out.
    """
    effects: list[Effect] = [
        HitchTransient(),
        SensorOffset("psi"),
        SensorOffset("omega"),
        SensorScale("omega"),
        SensorScale("psi"),
        ActuatorDelay(),
        ActuatorLag(),
        Understeer(),
        ClockOffset("hitch"),
        ClockOffset("odom"),
    ]
    if baseline == "transient":
        effects = [e for e in effects if not isinstance(e, HitchTransient)]
    return [e for e in effects if any(c in channels for c in e.channels)]
