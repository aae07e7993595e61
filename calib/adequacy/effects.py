"""The one effect hook every robot's catalogue fills in.

An effect is physics a nominal model leaves out, declared once: its id and target (the channel
or topic it acts on), its kind (a sensor's reading, an actuator's response, the dynamics, a
clock), its parameters with the value at which it does nothing, the explanations it is known to
be confounded with, the simulator switch that produces it and the truth key a study reads.
It also carries how it changes the model: ``model``, an object of the protocol its robot's
fitter defines (the fitter calls it and never branches on an effect's id), so an effect is added
to a robot by declaring one entry, hook included, in that robot's catalogue. The selection
(:func:`calib.adequacy.select_effects`, which asks the robot for a fit *with* a set of
effects), the confound check and the reports are shared.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Generic, TypeVar

__all__ = ["EffectKind", "EffectParam", "EffectSpec"]

H = TypeVar("H")


class EffectKind(StrEnum):
    """Where in the chain an effect acts."""

    SENSOR = "sensor"
    """What a sensor records differs from the true quantity (offset, gain, play, a stuck
    reading)."""
    ACTUATOR = "actuator"
    """The robot responds to its command otherwise than commanded (delay, lag)."""
    DYNAMICS = "dynamics"
    """The physics itself (slip, compliance, friction, a payload)."""
    CLOCK = "clock"
    """A topic's time stamps are off (an offset, a drift)."""


@dataclass(frozen=True)
class EffectParam:
    """One parameter of an effect: ``null`` is the value at which the effect does nothing;
    the fit keeps it within [``lower``, ``upper``] starting from ``init``."""

    name: str
    unit: str
    null: float
    lower: float
    upper: float
    init: float


@dataclass(frozen=True)
class EffectSpec(Generic[H]):
    """One catalogue entry (see the module docstring).

    ``physics``: what it means, in words, for reports; ``confounded_with``: keys of effects
    (or robot parameters, prefixed "param:") this one can be mistaken for; ``sim_switch``: the
    name of the simulator option that produces it; ``truth_key``: its key in a simulated log's
    truth; ``model``: how it changes the model, an object of the protocol ``H`` the robot's
    fitter defines (None for an entry whose robot has no such hook yet)."""

    id: str
    target: str
    kind: EffectKind
    params: tuple[EffectParam, ...]
    physics: str
    confounded_with: tuple[str, ...] = ()
    sim_switch: str = ""
    truth_key: str = ""
    model: H | None = field(default=None, compare=False, repr=False)

    @property
    def key(self) -> str:
        """``id(target)``, e.g. ``sensor_offset(psi)``, or ``id`` alone for an effect with no
        target (``actuator_delay``): unique within a catalogue."""
        return f"{self.id}({self.target})" if self.target else self.id
