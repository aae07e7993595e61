"""The arm's discovery in the shared shape (:class:`calib.discovery.DiscoveryReport`): the
catalogue effects named by the forward selection, the described residual model (terms of the
arm's own signals added to the torque model, :mod:`calib.manipulator.described`), the verdict
before and after, the parameters they moved and the alternatives the log does not tell apart.

An alternative explanation's parameters are the values that explanation implies; they are shown
with its own interval but never as determined: only the recommended estimate, which spans the
plausible explanations, is a calibrated answer. The arm's own records (baseline, trials,
selection diagnostics) stay under ``details``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from calib.adequacy import Adequacy
from calib.discovery import (
    BIC_MARGIN,
    Alternative,
    Description,
    DiscoveryReport,
    EffectSpec,
    FoundEffect,
    ModelFit,
    moved_parameters,
)
from calib.manipulator.discovery import ArmDiscovery, ArmFitter
from calib.manipulator.discovery.described import physics_hint
from calib.results import CalibrationResult, Estimate

__all__ = [
    "IMPLIED",
    "PartialEffect",
    "arm_discovery_report",
    "baseline_text",
    "described_alternative",
    "final_fit",
]

IMPLIED = "the value this explanation implies (its own interval; not a calibrated answer)"


def baseline_text(disc: ArmDiscovery) -> str:
    """The model discovery starts from, in words."""
    terms = ", ".join(disc.baseline) or "no friction or offset terms"
    body = "nominal (the log's link parameters)" if disc.nominal else "fitted"
    return f"rigid-body dynamics ({body}) + {terms}; torque acts as logged"


def _implied(e: Estimate) -> Estimate:
    return replace(e, identifiable=False, note=IMPLIED)


def _alternatives(disc: ArmDiscovery) -> tuple[Alternative, ...]:
    sel = disc.selection
    if sel is None:
        return ()
    out = []
    for c in sel.confounds:
        fit = c.alternative_fit
        pars = {k: _implied(e) for k, e in fit.parameters.items()}
        for effect in fit.effect_parameters.values():
            pars |= {k: _implied(e) for k, e in effect.items()}
        out.append(Alternative(c.alternative, pars, c.note))
    return tuple(out)


class PartialEffect(FoundEffect):
    """A catalogue effect the selection kept whose model, with it, still does not explain the
    log: it fits part of the residual, but what it fits may be other physics (play taken for a
    payload, a spring for gravity), so it is not given its name."""

    def line(self) -> str:
        vals = ", ".join(e.report() for e in self.parameters.values())
        return (
            f"fits part of the residual, not named: {self.key}: {vals} (the model with it does "
            "not explain the log)"
        )


def final_fit(disc: ArmDiscovery) -> ModelFit | None:
    """The model discovery ends with: after the residual model and the effects it made
    redundant, else the selection's."""
    if disc.final is not None:
        return disc.final
    d = disc.description
    if d is not None and d.accepted:
        return d.fit
    return None if disc.selection is None else disc.selection.final


def _catalogue_effects(disc: ArmDiscovery, fit: ModelFit, explains: bool) -> list[FoundEffect]:
    sel = disc.selection
    if sel is None:
        return []
    gains = {t.key: (t.heldout_gain, t.delta_bic) for t in sel.tried if t.accepted}
    out: list[FoundEffect] = []
    for s in sel.final.effects:
        if s.key in disc.dropped:
            continue
        e = FoundEffect.named(s, fit, *gains.get(s.key, (math.nan, math.nan)))
        out.append(e if explains else PartialEffect(**{**vars(e), "status": "partial"}))
    return out


def _described_effect(d: Description, fit: ModelFit) -> FoundEffect:
    """The kept description with its coefficients as the final fit has them, each term with
    what it most likely is (:func:`physics_hint`)."""
    pars = fit.effect_parameters.get(d.spec.key, {})
    terms = tuple(
        replace(t, coefficient=pars.get(t.coefficient.name, t.coefficient)) for t in d.terms
    )
    base = FoundEffect.described(d)
    hints = [f"{t.term.name}: {h}" for t in terms if (h := physics_hint(t.term))]
    physics = base.physics + (f" (likely {'; '.join(hints)})" if hints else "")
    return replace(
        base,
        physics=physics,
        parameters={t.coefficient.name: t.coefficient for t in terms},
        terms=terms,
    )


def _remaining(description: Description | None, after: Adequacy | None) -> str:
    if after is None or after.explains:
        return ""
    if description is not None and not description.accepted:
        return f"the torque residual follows {description.text} (not enough to be kept)"
    return after.unexplained or ""


def _notes(disc: ArmDiscovery) -> list[str]:
    out = [
        f"{k} was selected, but the residual model makes it redundant: not named"
        for k in disc.dropped
    ]
    d = disc.description
    if d is not None and d.accepted:
        out += [
            f"described term {t.term.name} on the {t.entry}: likely {h}"
            for t in d.terms
            if (h := physics_hint(t.term))
        ]
    return out


def described_alternative(
    fitter: ArmFitter, disc: ArmDiscovery, accepted: Sequence[EffectSpec]
) -> tuple[str, dict[str, Estimate]] | None:
    """A residual model not kept as an explanation the estimate must still span: when the
    description fits the log better by the BIC margin and improves the held-out fit, yet not by
    enough to be kept (a model that already explains needs 30 %), the data do not reject it, so
    the dynamic parameters it implies (``accepted`` + the description, fitted on the whole log)
    are an alternative (:func:`calib.manipulator.adequacy.spanned`). None otherwise."""
    d = disc.description
    if d is None or d.accepted or not (d.delta_bic < -BIC_MARGIN and d.heldout_gain > 0):
        return None
    fit = fitter.fit_arm((*accepted, d.spec))
    if fit is None:
        return None
    return "described (not kept)", fit.estimates()


def arm_discovery_report(
    disc: ArmDiscovery | None,
    before: Adequacy | None,
    after: Adequacy | None,
    estimate_before: CalibrationResult | None,
    estimate_after: CalibrationResult | None,
    *,
    description: Description | None = None,
    notes: Sequence[str] = (),
    not_run: str = "",
) -> DiscoveryReport:
    """The arm's findings in the shared shape (module docstring). ``before``/``after``: the
    verdicts of the identified model and of the final one; ``estimate_before``/``after``: the
    identification's estimate and the recommended one under the final model; ``description``:
    the residual model (kept or not); ``not_run``: why discovery did not run."""
    if disc is None or disc.selection is None:
        return DiscoveryReport(
            "manipulator",
            "rigid-body dynamics",
            before=before,
            after=after,
            notes=tuple(notes) + ((not_run,) if not_run else ()),
            status="not_run",
            details={} if disc is None else disc.to_dict(),
        )
    sel = disc.selection
    fit = final_fit(disc) or sel.final
    explains = after is None or after.explains
    effects = _catalogue_effects(disc, fit, explains)
    if description is not None and description.accepted:
        effects.append(_described_effect(description, fit))
    moved: Mapping[str, tuple[Estimate, Estimate]] = {}
    if estimate_before is not None and estimate_after is not None:
        moved = moved_parameters(estimate_before.parameters, estimate_after.parameters)
    details: dict[str, Any] = disc.to_dict()
    return DiscoveryReport(
        "manipulator",
        baseline_text(disc),
        tuple(effects),
        before,
        after,
        sel.base.heldout_sse,
        fit.heldout_sse,
        _remaining(description, after),
        _alternatives(disc),
        tuple(c.to_dict() for c in sel.confounds),
        moved,
        (*notes, *_notes(disc)),
        details,
        more=tuple(f"  {u}" for u in disc.untestable),
    )
