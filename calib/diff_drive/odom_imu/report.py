"""The odometry + IMU discovery in the shared shape (:class:`calib.discovery.DiscoveryReport`):
the named effects with their parameters re-estimated in the final model, the described terms
when kept, the verdict of the constant-gain model -> the final model's, the yaw-rate gain
before -> after, each confound's alternative with the gain it implies, what remains, and the
gain law's lines; the analysis' own records under ``details``."""

from __future__ import annotations

import math
from collections.abc import Mapping

from calib.diff_drive.odom_imu.law import GainLaw
from calib.diff_drive.odom_imu.result import OdomImuResult
from calib.discovery import Alternative, DiscoveryReport, EffectKind, FoundEffect, Selection
from calib.results import Estimate

__all__ = ["BASELINE", "odom_imu_discovery_report"]

BASELINE = "constant yaw-rate gain + gyro bias"


def _gains(sel: Selection) -> Mapping[str, tuple[float, float]]:
    return {t.key: (t.heldout_gain, t.delta_bic) for t in sel.tried if t.accepted}


def _heldout_constant(sel: Selection) -> float:
    """The held-out sum of squares of the constant-gain model (the baseline), from the first
    round's candidates; the nominal's when it was not tried."""
    for t in sel.tried:
        if t.round == 1 and t.key.startswith("effective_track") and t.fit is not None:
            return t.fit.heldout_sse
    return sel.base.heldout_sse


def _gain_of(law: GainLaw) -> Estimate:
    m = law.mean_gain
    return Estimate(m.name, m.value, m.std, m.ci95, m.identifiable, m.unit, m.note)


def odom_imu_discovery_report(res: OdomImuResult) -> DiscoveryReport:
    """``res``'s discovery (module docstring)."""
    sel, ex = res.selection, res.explained
    if sel is None or ex is None:
        return DiscoveryReport(
            "diff_drive",
            BASELINE,
            before=res.adequacy,
            after=res.adequacy,
            notes=tuple(res.notes),
            status="not_run",
            details=res.to_dict(),
        )
    fit = ex.final
    gains = _gains(sel)
    effects = [
        FoundEffect.named(e, fit, *gains.get(e.key, (math.nan, math.nan)))
        for e in fit.effects
        if str(e.kind) != str(EffectKind.DESCRIBED)
    ]
    d = ex.description
    if d is not None and d.accepted:
        effects.append(FoundEffect.described(d))
    after = res.final_adequacy
    remaining = ""
    if not after.explains:
        remaining = (
            f"what the model leaves follows {d.text} (not enough to be kept)"
            if d is not None and not d.accepted
            else (after.unexplained or "")
        ) or "no library term of speed and turn rate models what is left"
    moved: dict[str, tuple[Estimate, Estimate]] = {}
    if ex.law is not None:
        moved["yaw_rate_gain"] = (res.recommended_gain(under_law=False), res.recommended_gain())
    alternatives = tuple(
        Alternative(
            label, {"yaw_rate_gain": _gain_of(law)}, f"{law.formula}; {law.adequacy.verdict}"
        )
        for label, law in ex.alternatives.items()
    )
    more = tuple(f"  {x}" for x in ex.law.lines()) if ex.law is not None else ()
    return DiscoveryReport(
        "diff_drive",
        BASELINE,
        tuple(effects),
        res.adequacy,
        after,
        _heldout_constant(sel),
        fit.heldout_sse,
        remaining,
        alternatives,
        tuple(c.to_dict() for c in sel.confounds),
        moved,
        tuple(res.notes),
        res.to_dict(),
        more=more,
    )
