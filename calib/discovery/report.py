"""One result shape for discovery, whatever the robot: what the log holds beyond the nominal
model, named (a catalogue effect) or described (terms of the residual model), each with its
parameters and intervals, the held-out gain it brings, the verdict before and after, the robot's
parameters it moved, the alternatives the log does not tell apart and what remains.

Every robot fills a :class:`DiscoveryReport`; the JSON key ``discovery`` is its ``to_dict()``
(the robot's own records under ``details``), so that a batch table, a view or a user's script
reads one shape. ``lines()`` is its text for the report's first screen.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from calib.adequacy import Adequacy
from calib.discovery.base import EffectKind, EffectSpec, ModelFit
from calib.discovery.residual_model import DescribedTerm, Description
from calib.results import Estimate, json_safe

__all__ = [
    "Alternative",
    "DiscoveryReport",
    "FoundEffect",
    "found_effects",
    "moved_parameters",
    "verdict_record",
]


@dataclass(frozen=True)
class FoundEffect:
    """One effect in the final model: ``status`` "named" (a catalogue effect whose model is
    what explains) or "described" (terms of the residual model); its parameters (or the
    described terms' coefficients), the channel it acts on, and the held-out gain and BIC change
    it brought when it was added."""

    key: str
    id: str
    target: str
    kind: str
    status: str
    physics: str
    channel: str
    parameters: Mapping[str, Estimate]
    heldout_gain: float
    delta_bic: float
    terms: tuple[DescribedTerm, ...] = ()

    @classmethod
    def named(
        cls, spec: EffectSpec[Any], fit: ModelFit, heldout_gain: float, delta_bic: float
    ) -> FoundEffect:
        return cls(
            spec.key,
            spec.id,
            spec.target,
            str(spec.kind),
            "named",
            spec.physics,
            spec.target,
            dict(fit.effect_parameters.get(spec.key, {})),
            heldout_gain,
            delta_bic,
        )

    @classmethod
    def described(cls, d: Description) -> FoundEffect:
        return cls(
            d.spec.key,
            d.spec.id,
            d.spec.target,
            str(EffectKind.DESCRIBED),
            "described",
            d.text,
            d.spec.target,
            {t.coefficient.name: t.coefficient for t in d.terms},
            d.heldout_gain,
            d.delta_bic,
            d.terms,
        )

    def line(self) -> str:
        if self.status == "described":
            return f"described ({self.channel}): " + "; ".join(t.text for t in self.terms)
        vals = ", ".join(e.report() for e in self.parameters.values())
        return f"named {self.key}: {vals} ({self.physics})"

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "key": self.key,
                "id": self.id,
                "target": self.target,
                "kind": self.kind,
                "status": self.status,
                "physics": self.physics,
                "channel": self.channel,
                "parameters": {k: e.to_dict() for k, e in self.parameters.items()},
                "terms": [t.to_dict() for t in self.terms],
                "heldout_gain": self.heldout_gain,
                "delta_bic": self.delta_bic,
            }
        )


@dataclass(frozen=True)
class Alternative:
    """An explanation the log does not tell apart from the reported one, with the robot's
    parameters it implies (each with its own interval) and why it is listed."""

    label: str
    parameters: Mapping[str, Estimate]
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "label": self.label,
                "parameters": {k: e.to_dict() for k, e in self.parameters.items()},
                "note": self.note,
            }
        )


def verdict_record(a: Adequacy | None) -> dict[str, Any] | None:
    """The verdict, the worst channel and its judged ratio to its noise floor."""
    if a is None:
        return None
    worst = max(a.channels, key=lambda c: c.judged_ratio) if a.channels else None
    return json_safe(
        {
            "verdict": a.verdict,
            "model": a.model,
            "ratio": None if worst is None else worst.judged_ratio,
            "channel": None if worst is None else worst.channel,
        }
    )


def _implied_text(e: Estimate) -> str:
    """A value an alternative explanation implies, with its own interval (never a calibrated
    answer: only the recommended estimate, which spans the explanations, is one)."""
    lo, hi = e.ci95
    if not (math.isfinite(e.value) and math.isfinite(lo) and math.isfinite(hi)):
        return f"{e.name} not fixed by this explanation"
    return f"{e.name} = {e.value:.4g} {e.unit} [{lo:.4g}, {hi:.4g}]".replace("  ", " ")


def _ratio_text(a: Adequacy | None) -> str:
    rec = verdict_record(a)
    if rec is None:
        return "not assessed"
    r = rec["ratio"]
    return rec["verdict"] + ("" if r is None else f" ({rec['channel']} {r:.2g}x its floor)")


@dataclass(frozen=True)
class DiscoveryReport:
    """Discovery's findings on one log (module docstring).

    ``before``/``after``: the adequacy of the nominal and of the final model; ``heldout_before``
    / ``heldout_after``: their held-out sums of squares in noise units; ``described``: the
    residual the final model leaves is described (by terms in ``effects`` or in words in
    ``remaining``); ``moved``: robot parameters before -> after discovery."""

    robot: str
    baseline: str
    effects: tuple[FoundEffect, ...] = ()
    before: Adequacy | None = None
    after: Adequacy | None = None
    heldout_before: float = math.nan
    heldout_after: float = math.nan
    remaining: str = ""
    alternatives: tuple[Alternative, ...] = ()
    confounds: tuple[Mapping[str, Any], ...] = ()
    moved: Mapping[str, tuple[Estimate, Estimate]] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    details: Mapping[str, Any] = field(default_factory=dict)
    status: str = "ok"
    more: tuple[str, ...] = ()
    """The robot's own lines, shown after the findings (the engines' details)."""

    @property
    def named(self) -> list[str]:
        return [e.key for e in self.effects if e.status == "named"]

    @property
    def described(self) -> bool:
        return any(e.status == "described" for e in self.effects) or bool(self.remaining)

    def lines(self) -> list[str]:
        """The findings for people: the answer (:meth:`answer_lines`), then the robot's own
        lines (the engines' details)."""
        return [*self.answer_lines(), *self.more]

    def answer_lines(self) -> list[str]:
        """The findings a report never cuts: the named and described effects with their
        values, the verdict before -> after, what moved, what remains, the alternatives."""
        out = [f"Baseline: {self.baseline}"]
        if self.effects:
            out += [f"  {e.line()}" for e in self.effects]
        else:
            out.append("  no effect beyond the baseline improves the held-out fit")
        if self.before is not None or self.after is not None:
            out.append(f"  verdict: {_ratio_text(self.before)} -> {_ratio_text(self.after)}")
        b, a = self.heldout_before, self.heldout_after
        if self.effects and math.isfinite(b) and math.isfinite(a):
            out.append(f"  held-out sum of squares (noise units) {b:.4g} -> {a:.4g}")
        for e0, e1 in self.moved.values():
            out.append(f"  moved: {e0.report()} -> {e1.report()}")  # report() names it
        if self.remaining:
            out.append(f"  remaining: {self.remaining}")
        for alt in self.alternatives:
            vals = ", ".join(_implied_text(e) for e in alt.parameters.values())
            out.append(
                f"  alternative {alt.label} would imply {vals}"
                + (f" ({alt.note})" if alt.note else "")
            )
        out += [f"  note: {n}" for n in self.notes]
        return out

    def report(self) -> list[str]:
        """The "Model mismatch" panel's lines."""
        return self.lines()

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "engine": "calib.discovery",
                "robot": self.robot,
                "status": self.status,
                "baseline": self.baseline,
                "verdict_before": verdict_record(self.before),
                "verdict_after": verdict_record(self.after),
                "heldout_before": self.heldout_before,
                "heldout_after": self.heldout_after,
                "effects": [e.to_dict() for e in self.effects],
                "named": self.named,
                "described": self.described,
                "remaining": self.remaining,
                "alternatives": [a.to_dict() for a in self.alternatives],
                "confounds": [dict(c) for c in self.confounds],
                "moved": {
                    k: {"before": a.to_dict(), "after": b.to_dict()}
                    for k, (a, b) in self.moved.items()
                },
                "notes": list(self.notes),
                "details": dict(self.details),
            }
        )


def moved_parameters(
    before: Mapping[str, Estimate], after: Mapping[str, Estimate]
) -> dict[str, tuple[Estimate, Estimate]]:
    """The parameters whose value changed between two estimates (by more than 1e-12 relative)."""
    out = {}
    for k, a in before.items():
        b = after.get(k)
        if b is not None and abs(a.value - b.value) > 1e-12 * max(1.0, abs(a.value)):
            out[k] = (a, b)
    return out


def found_effects(
    fits: Sequence[tuple[EffectSpec[Any], ModelFit, float, float]],
) -> tuple[FoundEffect, ...]:
    """Named effects from (spec, the final fit, held-out gain, BIC change) tuples."""
    return tuple(FoundEffect.named(s, f, g, d) for s, f, g, d in fits)
