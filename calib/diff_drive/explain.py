"""From discovery's findings to the differential drive's explanation of a log: the data
corrected by the effects that explain it (so that the calibration is rerun under them), and the
findings in the shared discovery shape (:class:`calib.discovery.DiscoveryReport`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

from calib.adequacy import Adequacy
from calib.diff_drive.data import DriveRun
from calib.diff_drive.described import CORRECTING, corrected_runs
from calib.diff_drive.effects import CHAIN_ORDER, WHEEL_SLIP, DiffDriveSelection
from calib.diff_drive.odometry_lsq import calibrate_lsq
from calib.discovery import (
    Alternative,
    DiscoveryReport,
    EffectSpec,
    Explanation,
    FoundEffect,
    ModelFit,
    across,
    moved_parameters,
)
from calib.errors import CalibError
from calib.results import CalibrationResult, Estimate

__all__ = [
    "correcting_effects",
    "drive_discovery_report",
    "explained_runs",
    "explanations",
    "final_fit",
    "span_explanations",
]


def final_fit(disc: DiffDriveSelection) -> ModelFit | None:
    """The model discovery ends with: the selection's, with the described effect when it was
    accepted."""
    if disc.selection is None:
        return None
    d = disc.description
    return d.fit if d is not None and d.accepted else disc.selection.final


def correcting_effects(disc: DiffDriveSelection) -> tuple[EffectSpec, ...]:
    """The effects of the final model that correct the data (clock shifts, described terms)."""
    fit = final_fit(disc)
    if fit is None:
        return ()
    return tuple(e for e in fit.effects if str(e.kind) in CORRECTING)


def explained_runs(runs: Sequence[DriveRun], disc: DiffDriveSelection) -> list[DriveRun] | None:
    """``runs`` corrected by the correcting effects of the final model, or None when it has
    none."""
    fit = final_fit(disc)
    effects = correcting_effects(disc)
    if fit is None or not effects:
        return None
    return corrected_runs(runs, fit.effects, fit, {str(k): v for k, v in CHAIN_ORDER.items()})


def _slip_effect(k: Estimate) -> FoundEffect:
    """Speed-dependent slip named by its own joint fit (``calib.diff_drive.slip``)."""
    return FoundEffect(
        WHEEL_SLIP.key,
        WHEEL_SLIP.id,
        WHEEL_SLIP.target,
        str(WHEEL_SLIP.kind),
        "named",
        WHEEL_SLIP.physics,
        WHEEL_SLIP.target,
        {"k": k},
        math.nan,
        math.nan,
    )


def _gains(disc: DiffDriveSelection) -> Mapping[str, tuple[float, float]]:
    sel = disc.selection
    out: dict[str, tuple[float, float]] = {}
    for t in sel.tried if sel is not None else ():
        if t.accepted:
            out[t.key] = (t.heldout_gain, t.delta_bic)
    return out


def drive_discovery_report(
    disc: DiffDriveSelection | None,
    before: Adequacy | None,
    after: Adequacy | None,
    estimate_before: CalibrationResult | None,
    estimate_after: CalibrationResult | None,
    baseline: str,
    slip: Estimate | None = None,
    runs: Sequence[DriveRun] = (),
    seed: int = 0,
) -> DiscoveryReport:
    """The findings in the shared shape: the named effects and the described one, the verdict
    before and after, the parameters they moved, the confounds and what remains. ``runs``: the
    data as recorded, for each alternative's parameters as the same least squares calibrates
    them under it (the fitter's own parameters hold the track at its nominal value unless an
    effect frees it, so they are not comparable with the estimate's); none given: none shown."""
    if disc is None or disc.selection is None:
        notes = tuple(disc.notes) if disc is not None else ()
        return DiscoveryReport(
            "diff_drive",
            baseline,
            before=before,
            after=after,
            notes=notes,
            status="not_run",
            details={} if disc is None else disc.to_dict(),
        )
    sel = disc.selection
    fit = final_fit(disc) or sel.final
    gains = _gains(disc)
    effects = [
        FoundEffect.named(e, fit, *gains.get(e.key, (math.nan, math.nan)))
        for e in sel.final.effects
    ]
    if slip is not None:
        effects.append(_slip_effect(slip))
    d = disc.description
    if d is not None and d.accepted:
        effects.append(FoundEffect.described(d))
    remaining = ""
    if after is not None and not after.explains:
        remaining = (
            f"what the model leaves follows {d.text} (not enough to be kept)"
            if d is not None and not d.accepted
            else (after.unexplained or "")
        )
    moved = (
        moved_parameters(estimate_before.parameters, estimate_after.parameters)
        if estimate_before is not None and estimate_after is not None
        else {}
    )
    alternatives = tuple(
        Alternative(
            c.alternative, _implied(_calibrated_under(runs, c.alternative_fit, seed)), c.note
        )
        if runs
        else Alternative(c.alternative, {}, c.note)
        for c in sel.confounds
    )
    return DiscoveryReport(
        "diff_drive",
        baseline,
        tuple(effects),
        before,
        after,
        sel.base.heldout_sse,
        fit.heldout_sse,
        remaining,
        alternatives,
        tuple(c.to_dict() for c in sel.confounds),
        moved,
        tuple(disc.notes),
        disc.to_dict(),
    )


IMPLIED = "the value this explanation implies (its own interval; not a calibrated answer)"


def _implied(pars: Mapping[str, Estimate] | None) -> dict[str, Estimate]:
    """An alternative's parameters as values it implies, never as determined (only the
    recommended estimate, which spans the plausible explanations, is a calibrated answer)."""
    return {
        k: dataclasses.replace(e, identifiable=False, note=IMPLIED) for k, e in (pars or {}).items()
    }


def _calibrated_under(
    runs: Sequence[DriveRun], fit: ModelFit, seed: int
) -> Mapping[str, Estimate] | None:
    """The radii and track of the least-squares calibration on ``runs`` corrected by ``fit``'s
    correcting effects (the same estimator for every explanation, so that they are compared
    alike)."""
    fixed = (
        corrected_runs(runs, fit.effects, fit, {str(k): v for k, v in CHAIN_ORDER.items()})
        if any(str(e.kind) in CORRECTING for e in fit.effects)
        else list(runs)
    )
    try:
        res, _ = calibrate_lsq(fixed, seed=seed)
    except CalibError:
        return None
    return dict(res.parameters)


def explanations(
    disc: DiffDriveSelection, best: CalibrationResult, runs: Sequence[DriveRun], seed: int
) -> list[Explanation]:
    """The explanations of a log discovery compared: the final model (its parameters the
    calibration ``best`` under it), the nominal model, each confound's alternative and a
    description that was not kept, each with the least-squares calibration of the data as that
    explanation corrects them."""
    sel, fit = disc.selection, final_fit(disc)
    if sel is None or fit is None:
        return []
    out = [Explanation("final", fit, dict(best.parameters))]
    others: list[tuple[str, ModelFit]] = [(c.alternative, c.alternative_fit) for c in sel.confounds]
    if sel.final.effects or (disc.description is not None and disc.description.accepted):
        others.insert(0, ("nominal", sel.base))
    d = disc.description
    if d is not None and not d.accepted:
        others.append(("described", d.fit))
    for label, f in others:
        pars = _calibrated_under(runs, f, seed)
        if pars is not None:
            out.append(Explanation(label, f, pars))
    return out


def span_explanations(
    result: CalibrationResult,
    disc: DiffDriveSelection,
    runs: Sequence[DriveRun],
    seed: int = 0,
    *,
    misfit: float | None = None,
) -> CalibrationResult | None:
    """``result`` with each radius and the track spanning the plausible explanations
    (:func:`calib.discovery.across`): determined where they agree, the interval their union;
    ``runs``: the data as recorded; ``misfit``: the final model's worst residual over its floor
    when it does not explain the log (each interval widened by it, nothing determined; None
    while it explains). None when
    there is no other explanation to span."""
    ex = explanations(disc, result, runs, seed)
    if len(ex) < 2:
        return None
    spanned = across(ex, ex[0], list(result.parameters), misfit=misfit)
    used = sorted({lab for s in spanned.values() for lab in s.values if lab != "final"})
    if not used:
        return None
    params = {k: spanned[k].estimate if k in spanned else e for k, e in result.parameters.items()}
    agree = all(s.agree for s in spanned.values())
    what = "agree" if agree else "disagree: not determined"
    if misfit is not None:
        what += f"; the model does not explain the log: each widened x{misfit:.2g}, not determined"
    verdict = result.verdict + (
        f"; the intervals span the explanations that fit this log ({', '.join(used)}), which {what}"
    )
    return replace(result, parameters=params, covariance=None, verdict=verdict)
