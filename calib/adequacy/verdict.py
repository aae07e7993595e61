"""The adequacy verdict: does the model explain the recording, channel by channel, and where
does it not.

A channel is explained when its residual RMS (held out when the robot computed a held-out
residual, else in-sample) is within ``EXPLAINS_RATIO`` of the noise floor estimated from the
data (:mod:`calib.adequacy.noise`), and not significantly above it: a ratio over
``SIGNIFICANT_RATIO`` whose excess is ``SIGNIFICANT_Z`` standard errors from one (counted at the
residual's effective sample size) does not explain the log either; a long log shows a small
systematic misfit that a short one cannot. The model explains the log when every channel is
explained.
Whiteness (Ljung-Box at the noise's own time scale) is reported beside it, not decisive: at
hundreds of hertz any real sensor's noise is coloured.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from calib.adequacy.channel import ResidualChannel
from calib.adequacy.locate import Location, locate
from calib.adequacy.noise import NoiseFloor, noise_floor
from calib.adequacy.whiteness import ljung_box
from calib.results import JsonRecord, json_safe
from calib.stats import effective_samples

__all__ = [
    "EXPLAINS",
    "EXPLAINS_RATIO",
    "NOT_ASSESSED",
    "NOT_EXPLAINED",
    "Adequacy",
    "ChannelAdequacy",
    "ParameterChange",
    "assess",
    "describe_misfit",
    "not_assessed",
]

EXPLAINS = "explains"
NOT_EXPLAINED = "does not explain"
NOT_ASSESSED = "not assessed"

EXPLAINS_RATIO = 1.5
"""A channel is explained while its residual RMS is at most this times its noise floor..."""
SIGNIFICANT_RATIO = 1.2
SIGNIFICANT_Z = 5.0
"""... and while a ratio above SIGNIFICANT_RATIO is not SIGNIFICANT_Z standard errors above one."""


@dataclass(frozen=True)
class ChannelAdequacy(JsonRecord):
    """One channel's residual against its noise floor.

    ``ratio``: in-sample residual RMS / floor; ``heldout_ratio``: the same for the held-out
    residual (None: not computed); ``whiteness_p``: Ljung-Box p-value of the residual sampled
    at the noise's time scale; ``explains``: the judged ratio is within ``EXPLAINS_RATIO``."""

    channel: str
    unit: str
    n: int
    residual_rms: float
    noise_floor: float
    noise: NoiseFloor
    ratio: float
    heldout_rms: float | None
    heldout_ratio: float | None
    whiteness_p: float | None
    explains: bool

    @property
    def judged_ratio(self) -> float:
        return self.heldout_ratio if self.heldout_ratio is not None else self.ratio


@dataclass(frozen=True)
class ParameterChange(JsonRecord):
    """A parameter that changes mid-log: ``t_s`` the change (s from the start, with its
    uncertainty ``t_range_s``), ``before``/``after`` the piecewise values, ``statistic`` the
    chi-square of one constant value against two, ``note`` for people."""

    t_s: float
    t_range_s: tuple[float, float]
    parameters: tuple[str, ...]
    before: Mapping[str, float]
    after: Mapping[str, float]
    statistic: float
    note: str


@dataclass(frozen=True)
class Adequacy:
    """Whether the model explains the log (``verdict``), per channel, and where not.

    ``model``: the model judged (e.g. "transient path + sensor_offset(psi)"); ``before``: the
    baseline's adequacy when discovery added effects (the fit improving is shown by the two);
    ``located``: where the residual stands above the noise; ``changes``: parameters that change
    mid-log; ``unexplained``: what no catalogued effect explains, described; ``summary``: one
    sentence for people; ``reason``: why not assessed."""

    verdict: str
    model: str
    channels: Sequence[ChannelAdequacy] = ()
    located: Sequence[Location] = ()
    changes: Sequence[ParameterChange] = ()
    unexplained: str | None = None
    before: Adequacy | None = None
    reason: str = ""
    notes: Sequence[str] = field(default_factory=tuple)
    described_by_robot: bool = True
    """False when ``unexplained`` is the generic description of the located misfit."""

    @property
    def explains(self) -> bool:
        return self.verdict == EXPLAINS

    @property
    def misfit_factor(self) -> float:
        """How far the worst channel's residual exceeds its floor (>= 1): the factor a
        model-conditional interval is widened by when the model does not explain the log."""
        ratios = [c.judged_ratio for c in self.channels if math.isfinite(c.judged_ratio)]
        return max([1.0, *ratios])

    @property
    def summary(self) -> str:
        if self.verdict == NOT_ASSESSED:
            return (
                f"Model adequacy not assessed: {self.reason}"
                if self.reason
                else ("Model adequacy not assessed")
            )
        worst = max(self.channels, key=lambda c: c.judged_ratio)
        held = " held out" if worst.heldout_ratio is not None else ""
        head = (
            f"The model ({self.model}) explains the log: the{held} residual of "
            f"{worst.channel} is {worst.judged_ratio:.2g}x its noise floor"
            if self.explains
            else f"The model ({self.model}) does not explain the log: the{held} residual of "
            f"{worst.channel} is {worst.judged_ratio:.2g}x its noise floor "
            f"({worst.noise_floor:.3g} {worst.unit}, from {worst.noise.source})"
        )
        if not self.explains and self.located:
            labels = list(dict.fromkeys(loc.label for loc in self.located))
            head += "; " + ", ".join(labels[:3])
        if self.unexplained and self.described_by_robot:
            head += f". Unexplained: {self.unexplained}"
        if self.changes:
            head += ". " + "; ".join(c.note for c in self.changes)
        return head + "."

    def with_(self, **changes: Any) -> Adequacy:
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "verdict": self.verdict,
            "model": self.model,
            "summary": self.summary,
            "misfit_factor": self.misfit_factor if self.channels else None,
            "channels": [{**c.to_dict(), "judged_ratio": c.judged_ratio} for c in self.channels],
            "located": [loc.to_dict() for loc in self.located],
            "changes": [c.to_dict() for c in self.changes],
            "unexplained": self.unexplained,
            "before": None if self.before is None else self.before.to_dict(),
            "reason": self.reason,
            "notes": list(self.notes),
        }
        safe: dict[str, Any] = json_safe(out)
        return safe


def not_assessed(model: str, reason: str) -> Adequacy:
    """An adequacy that could not be judged (too few samples, no residual), with why."""
    return Adequacy(NOT_ASSESSED, model, reason=reason)


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return math.sqrt(float(np.mean(x * x))) if x.size else math.nan


def _channel(ch: ResidualChannel, ratio_limit: float) -> ChannelAdequacy:
    t = np.asarray(ch.t_s, dtype=float)
    r = np.asarray(ch.residual, dtype=float)
    floor = noise_floor(
        t,
        r,
        measured=ch.measured,
        quantum=ch.quantum,
        timescale_s=ch.timescale_s,
        input_std=ch.input_std,
    )
    rms = _rms(r)
    f = floor.std if floor.std > 0 else math.nan
    held_rms = held_ratio = None
    if ch.heldout is not None and np.isfinite(ch.heldout).sum() >= 10:
        held_rms = _rms(np.asarray(ch.heldout, dtype=float))
        held_ratio = held_rms / f
    ok = np.isfinite(t) & np.isfinite(r)
    white_p = None
    if ok.sum() >= 40:
        dt = float(np.median(np.diff(t[ok])))
        step = max(1, round(ch.timescale_s / dt)) if dt > 0 else 1
        white_p = ljung_box(r[ok][::step], 20)[1] if ok.sum() // step >= 40 else None
    judged = held_ratio if held_ratio is not None else rms / f
    n_eff = effective_samples(
        ch.heldout if held_ratio is not None and ch.heldout is not None else r
    )
    z = (judged**2 - 1.0) * math.sqrt(n_eff / 2.0) if math.isfinite(judged) else math.inf
    significant = judged > SIGNIFICANT_RATIO and z > SIGNIFICANT_Z
    explains = bool(math.isfinite(judged) and judged <= ratio_limit and not significant)
    if floor.std <= 0 and rms == 0:
        explains = True
    return ChannelAdequacy(
        ch.name,
        ch.unit,
        int(ok.sum()),
        rms,
        floor.std,
        floor,
        rms / f,
        held_rms,
        held_ratio,
        white_p,
        explains,
    )


def describe_misfit(channels: Sequence[ChannelAdequacy], located: Sequence[Location]) -> str:
    """What the model leaves, in words: each unexplained channel's ratio to its floor and the
    places its excess concentrates (the robot's own description, when it has one, replaces
    this)."""
    parts = []
    for c in channels:
        if c.explains:
            continue
        where = list(dict.fromkeys(loc.label for loc in located if loc.channel == c.channel))
        parts.append(
            f"{c.channel} keeps {c.judged_ratio:.2g}x its noise floor"
            + (f", concentrated at {', '.join(where[:3])}" if where else "")
        )
    return "; ".join(parts)


def assess(
    channels: Sequence[ResidualChannel],
    *,
    model: str,
    before: Adequacy | None = None,
    changes: Sequence[ParameterChange] = (),
    unexplained: str | None = None,
    ratio_limit: float = EXPLAINS_RATIO,
    min_samples: int = 20,
    notes: Sequence[str] = (),
) -> Adequacy:
    """Judge ``model`` by its residual ``channels``: per channel the noise floor, ratios,
    whiteness; located misfit; the verdict. A parameter change mid-log makes the verdict
    "does not explain" (one set of parameters does not describe the log)."""
    usable = [
        c for c in channels if np.isfinite(np.asarray(c.residual, float)).sum() >= min_samples
    ]
    if not usable:
        return not_assessed(model, f"fewer than {min_samples} residual samples")
    judged = [_channel(c, ratio_limit) for c in usable]
    located: list[Location] = []
    for ch, res in zip(usable, judged, strict=True):
        if not res.explains:
            located += locate(ch, res.noise_floor, ratio_limit)
    explains = all(c.explains for c in judged) and not changes
    by_robot = True
    if not explains and unexplained is None:
        unexplained = describe_misfit(judged, located) or None
        by_robot = False
    return Adequacy(
        EXPLAINS if explains else NOT_EXPLAINED,
        model,
        tuple(judged),
        tuple(located),
        tuple(changes),
        unexplained,
        before,
        notes=tuple(notes),
        described_by_robot=by_robot,
    )
