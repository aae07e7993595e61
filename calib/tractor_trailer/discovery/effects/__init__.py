"""The catalogue of physical effects: one interface (``Effect``), one module per effect.

To add an effect, subclass ``Effect`` (its hooks and its catalogue entry's declarations: kind,
confounds, simulator switch, the explanations it is equivalent to and how their parameters
convert, ``Effect.equivalents``, and what it says about the joint-angle sensor,
``Effect.joint_angle_correction``) and list an instance in ``catalogue``, or, from outside the
package, pass its factory to ``register_effect`` (one line).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

from calib.discovery import EffectRegistry
from calib.tractor_trailer.discovery.effects.actuator_delay import ActuatorDelay
from calib.tractor_trailer.discovery.effects.actuator_lag import ActuatorLag
from calib.tractor_trailer.discovery.effects.base import (
    Effect,
    Equivalent,
    ParamSpec,
    SensorCorrections,
)
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
    "Equivalent",
    "HitchTransient",
    "ParamSpec",
    "SensorCorrections",
    "SensorOffset",
    "SensorScale",
    "Understeer",
    "catalogue",
    "register_effect",
    "unregister_effect",
]


def _builtin() -> list[Effect]:
    return [
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


REGISTRY: EffectRegistry[Callable[[], Effect]] = EffectRegistry(
    "tractor-trailer (command-driven)",
    key=lambda make: make().key,
    builtin=lambda: (e.key for e in _builtin()),
)
"""Factories of effects added from outside (a fresh effect per catalogue: effects remember
their intermediate results), with ``calib.discovery``'s one registry behaviour."""


def register_effect(factory: Callable[[], Effect]) -> Callable[[], Effect]:
    """Add the effect ``factory()`` makes to every later ``catalogue``, after the built-in
    ones; returns the factory (ValueError: its key is taken by another effect)."""
    return REGISTRY.register(factory)


def unregister_effect(key: str | Callable[[], Effect]) -> None:
    """Remove the registered effect ``key`` (the built-in ones stay)."""
    REGISTRY.unregister(key)


def catalogue(
    baseline: Literal["steady", "transient"] = "steady",
    channels: tuple[str, ...] = ("omega", "psi"),
) -> list[Effect]:
    """Candidate effects of the tractor-trailer for ``baseline`` and the recorded ``channels``.

    An effect whose physics a baseline already contains (``Effect.in_baselines``: the
    hitch transient in the transient baseline) is left out against it, and so are effects on a
    channel that was not recorded. Registered effects (``register_effect``) follow the
    built-in ones.
    """
    effects = [*_builtin(), *(make() for make in REGISTRY.entries())]
    effects = [e for e in effects if baseline not in e.in_baselines]
    return [e for e in effects if any(c in channels for c in e.channels)]
