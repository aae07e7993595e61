"""Plausibility: answers a fit can give that no real machine has, said with their likely cause.

A calibration can fit well and still be wrong in a way the residual does not show: a joint angle
logged in degrees but read as radians fits a model with absurd link lengths and leaves a
residual *far below* its own noise floor (the floor is read off the signal, which the wrong unit
rescales together with the model's error). Two checks, for every robot:

- *below the floor*: a channel whose residual is under ``BELOW_FLOOR`` x the recording's own
  high-frequency noise (the floor without the noise the model's inputs carry in): the
  model follows the recording more closely than the recording's own noise allows, which a model
  fitted to a rescaled or duplicated signal does (a unit, a scale, the model's input logged as
  its output);
- *outside physical sense*: a parameter outside the range the robot declares for it
  (:class:`PhysicalRange`: a link length, a wheel radius, a mass, a gain), with the causes the
  robot names for it (a unit, a sign, a scale, a topic).

An implausible parameter is not determined by the log, whatever its interval: the report says
what is implausible and why it may be.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from calib.adequacy.verdict import Adequacy, ChannelAdequacy
from calib.results import CalibrationResult, Estimate

__all__ = [
    "BELOW_FLOOR",
    "Implausible",
    "PhysicalRange",
    "implausible",
    "mark_implausible",
]

BELOW_FLOOR = 0.3
"""A residual under this fraction of its noise floor is implausible for a real recording."""


@dataclass(frozen=True)
class PhysicalRange:
    """The values a quantity of a real machine of this kind takes: ``lo`` to ``hi`` (its unit),
    and the likely ``causes`` of a fit outside them."""

    name: str
    lo: float
    hi: float
    unit: str
    causes: str


@dataclass(frozen=True)
class Implausible:
    """What is implausible (``quantity``), its value, why and the likely cause."""

    quantity: str
    value: float
    why: str
    cause: str

    @property
    def text(self) -> str:
        return f"{self.quantity} = {self.value:.4g}: {self.why}; likely cause: {self.cause}"


def _own_noise_ratio(c: ChannelAdequacy) -> float:
    """The residual over the recording's own high-frequency noise (the floor without what the
    model's inputs carry in: a noise-free simulation whose floor is all input noise is not
    implausible)."""
    own = c.noise.white_std if math.isfinite(c.noise.white_std) and c.noise.white_std > 0 else 0.0
    if own <= 0.0:
        return c.judged_ratio
    rms = c.heldout_rms if c.heldout_rms is not None and math.isfinite(c.heldout_rms) else None
    return (rms if rms is not None else c.residual_rms) / own


def implausible(
    estimate: CalibrationResult | None,
    adequacy: Adequacy | None,
    ranges: Sequence[PhysicalRange],
    *,
    derived: Mapping[str, Estimate] | None = None,
    below_floor_cause: str = "the recorded signal is rescaled (a unit such as degrees for "
    "radians, a scale) or the model's own input was recorded as its output",
) -> list[Implausible]:
    """The implausible findings of one analysis (module docstring)."""
    out: list[Implausible] = []
    for c in adequacy.channels if adequacy is not None else ():
        r = _own_noise_ratio(c)
        if math.isfinite(r) and r < BELOW_FLOOR and c.residual_rms > 0:
            out.append(
                Implausible(
                    f"{c.channel} residual",
                    r,
                    f"{r:.2g}x its own noise floor, closer than the recording's noise allows",
                    below_floor_cause,
                )
            )
    values: dict[str, Estimate] = {}
    if estimate is not None:
        values.update(estimate.parameters)
        values.update(estimate.derived)
    values.update(derived or {})
    for rng in ranges:
        e = values.get(rng.name)
        if e is None or not math.isfinite(e.value):
            continue
        if not rng.lo <= e.value <= rng.hi:
            out.append(
                Implausible(
                    rng.name,
                    e.value,
                    f"outside {rng.lo:g} to {rng.hi:g} {rng.unit}, where machines of this kind lie",
                    rng.causes,
                )
            )
    return out


def mark_implausible(
    estimate: CalibrationResult, found: Sequence[Implausible]
) -> CalibrationResult:
    """``estimate`` with every parameter not determined and the verdict saying what is
    implausible, when ``found`` holds anything; else unchanged."""
    if not found:
        return estimate
    why = "; ".join(f.text for f in found)
    short = "implausible for a real machine (see the verdict)"

    def undetermined(e: Estimate) -> Estimate:
        return replace(e, identifiable=False, note=f"{e.note}; {short}" if e.note else short)

    return replace(
        estimate,
        parameters={k: undetermined(e) for k, e in estimate.parameters.items()},
        derived={k: undetermined(e) for k, e in estimate.derived.items()},
        verdict=f"Not determined: implausible for a real machine: {why}. The fit alone says "
        + ", ".join(f"{k} = {e.value:.4g} {e.unit}" for k, e in estimate.parameters.items())
        + ".",
    )
