"""The discovery engine's protocols: what an effect declares, what a fit of a model with effects
returns, and what a robot's fitter must do.

An effect is physics a nominal model leaves out, declared once (:class:`EffectSpec`): its id and
target (the channel or topic it acts on), its kind (a sensor's reading, an actuator's response,
the dynamics, a clock), its parameters with the value at which it does nothing, the explanations
it is known to be confounded with, the simulator switch that produces it and the truth key a
study reads. It also carries how it changes the model: ``model``, an object of the protocol its
robot's fitter defines (the fitter calls it and never branches on an effect's id), so an effect
is added to a robot by declaring one entry, hook included, in that robot's catalogue
(:class:`calib.discovery.registry.EffectRegistry`).

A robot's fitter (:class:`Fitter`) fits its model with a set of effects and returns a
:class:`ModelFit`; the selection (:mod:`calib.discovery.selection`), the confirmation
(:mod:`calib.discovery.confirm`), the residual model (:mod:`calib.discovery.residual_model`) and the
reports are shared. This is pysindy's split of one model over pluggable parts: here the parts are
the robot's fitter and catalogue, the engine the rest.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Generic, Protocol, TypeVar

from calib.results import Estimate
from calib.stats import bic_gaussian

__all__ = [
    "CandidateFailedError",
    "EffectKind",
    "EffectParam",
    "EffectSpec",
    "Fitter",
    "ModelFit",
]

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
    DESCRIBED = "described"
    """Not a catalogue entry: terms of the residual model (:mod:`calib.discovery.residual_model`)
    that describe what the catalogue leaves out, in the signals they follow."""


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


@dataclass(frozen=True)
class ModelFit:
    """The nominal model plus ``effects``, fitted.

    ``parameters``: the robot's parameters; ``effect_parameters``: by effect key, its
    parameters (standard errors as the robot reports them); ``sse``: in-sample sum of squared
    residuals over the noise floor (so channels in different units add); ``heldout_sse``: the
    same on held-out samples (math.nan: none); ``n``: samples; ``k``: fitted parameters;
    ``n_heldout``: held-out samples (default ``n``); ``n_eff``: the effective number of
    independent samples when the residuals are correlated (a 500 Hz torque, overlapping
    windows; default ``n``): the BIC then counts evidence at that rate, so that correlated
    samples do not make every candidate clear its margin; ``bic_value``: the fitter's own BIC
    when it counts evidence otherwise (per channel, say), replacing :attr:`bic`;
    ``heldout_rms``: held-out RMS per channel (the channel's unit), for rules that judge an
    effect on the channels it acts on; ``at_bound``: an effect parameter sits on a bound of its
    fit (a bounded optimum is no estimate); ``payload``: whatever the robot needs again
    (residual channels, its estimator object)."""

    effects: tuple[EffectSpec[Any], ...]
    parameters: Mapping[str, Estimate]
    effect_parameters: Mapping[str, Mapping[str, Estimate]]
    sse: float
    heldout_sse: float
    n: int
    k: int
    payload: Any = field(default=None, compare=False, repr=False)
    n_heldout: int | None = None
    n_eff: float | None = None
    bic_value: float | None = None
    heldout_rms: Mapping[str, float] = field(default_factory=dict)
    at_bound: bool = False

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(e.key for e in self.effects)

    @property
    def label(self) -> str:
        return " + ".join(self.keys) if self.effects else "nominal"

    @property
    def bic(self) -> float:
        """The fitter's BIC (``bic_value``), else at the effective sample size:
        n_eff ln(sse / n) + k ln(n_eff)."""
        if self.bic_value is not None:
            return self.bic_value
        return bic_gaussian(self.sse, self.n, self.k, self.n_eff)

    def z_scores(self, spec: EffectSpec[Any]) -> dict[str, float]:
        """Distance of ``spec``'s parameters from their null values in standard errors (0 where
        a parameter has no finite positive standard error)."""
        pars = self.effect_parameters.get(spec.key, {})
        out: dict[str, float] = {}
        for p in spec.params:
            e = pars.get(p.name)
            ok = e is not None and math.isfinite(e.std) and e.std > 0
            out[p.name] = abs(e.value - p.null) / e.std if ok and e is not None else 0.0
        return out


class CandidateFailedError(Exception):
    """A fitter's fit of one candidate set failed for a reason worth recording (the selection
    records ``reason`` against the candidate and goes on with the others)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class Fitter(Protocol):
    """A robot's model fitted with a set of effects (the engine's one hook into a robot).

    Returns None when that fit fails (the candidate is then left out), or raises
    :class:`CandidateFailedError` to have the reason recorded."""

    def __call__(self, effects: tuple[EffectSpec[Any], ...], /) -> ModelFit | None: ...
