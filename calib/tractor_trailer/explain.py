"""The tractor-trailer's discovery in the shared shape (:class:`calib.discovery.DiscoveryReport`):
the effects named along the measured path (the recommended engine) and by the command-driven
discovery, the described residual model, the verdict before and after, the link lengths they
moved and the alternatives the log does not tell apart.

An alternative explanation's link lengths are the values that explanation implies; they are
shown with its own interval but never as determined: only the recommended estimate, which spans
the plausible explanations, is a calibrated answer.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from calib.adequacy import Adequacy
from calib.discovery import Alternative, DiscoveryReport, FoundEffect, moved_parameters
from calib.results import CalibrationResult, Estimate
from calib.stats import Z95
from calib.tractor_trailer.discovery.result import DiscoveryResult, EffectFit
from calib.tractor_trailer.path_discovery import PathDiscovery

__all__ = ["tractor_discovery_report"]

BASELINE = (
    "transient off-axle kinematics along the measured path: d psi/ds = kappa (1 + L1/L2 cos "
    "psi) - sin(psi)/L2, ideal sensors and clocks"
)
IMPLIED = "the value this explanation implies (its own interval; not a calibrated answer)"


def _implied(name: str, value: float, std: float, unit: str = "m") -> Estimate:
    half = Z95 * std if math.isfinite(std) else math.inf
    return Estimate(name, value, std, (value - half, value + half), False, unit, IMPLIED)


def _command_effect(e: EffectFit) -> FoundEffect:
    gain = math.nan
    chans = [c for c in e.channels if c in e.rms_before and e.rms_before[c] > 0]
    if chans:
        gain = max(1.0 - (e.rms_after[c] / e.rms_before[c]) ** 2 for c in chans)
    return FoundEffect(
        e.label,
        e.id,
        e.target or "",
        e.kind,
        "named",
        e.explanation,
        ", ".join(e.channels),
        dict(e.estimates),
        gain,
        e.delta_bic,
    )


def _path_effects(disc: PathDiscovery) -> list[FoundEffect]:
    sel = disc.selection
    if sel is None:
        return []
    gains = {t.key: (t.heldout_gain, t.delta_bic) for t in sel.tried if t.accepted}
    out = [
        FoundEffect.named(s, sel.final, *gains.get(s.key, (math.nan, math.nan)))
        for s in sel.final.effects
    ]
    d = disc.description
    if d is not None and d.accepted:
        out.append(FoundEffect.described(d))
    return out


def _alternatives(
    path: PathDiscovery | None, command: DiscoveryResult | None
) -> tuple[Alternative, ...]:
    out: list[Alternative] = []
    for label, pars in path.alternatives if path is not None else ():
        lengths = {
            k: _implied(k, e.value, e.std) for k, e in dict(pars).items() if k in ("L1", "L2")
        }
        out.append(Alternative(str(label), lengths, "along the measured path"))
    for c in command.confounds if command is not None else ():
        ex = c.alternative  # the reported side is the recommended estimate's explanation
        lengths = {k: _implied(k, v, ex.std.get(k, math.nan)) for k, v in ex.parameters.items()}
        out.append(Alternative(ex.label, lengths, f"against {c.reported.label}: {c.why}"))
    return tuple(out)


def _notes(command: DiscoveryResult | None, notes: Sequence[str]) -> tuple[str, ...]:
    """The caller's notes, then what part of a long log the command-driven discovery used."""
    out = list(notes)
    if command is not None and command.windows is not None:
        out.append(command.windows.note())
    return tuple(out)


def _remaining(path: PathDiscovery | None, after: Adequacy | None) -> str:
    if after is None or after.explains:
        return ""
    d = path.description if path is not None else None
    if d is not None and not d.accepted:
        return f"the joint angle's residual follows {d.text} (not enough to be kept)"
    return after.unexplained or ""


def tractor_discovery_report(
    path: PathDiscovery | None,
    command: DiscoveryResult | None,
    adequacy: Adequacy | None,
    estimate_before: CalibrationResult | None,
    estimate_after: CalibrationResult | None,
    notes: Sequence[str] = (),
) -> DiscoveryReport:
    """Both engines' findings in the shared shape (module docstring); ``adequacy``: the final
    verdict of the recommended estimate's model."""
    effects = _path_effects(path) if path is not None and path.status == "ok" else []
    have = {e.key for e in effects}
    if command is not None:
        effects += [_command_effect(e) for e in command.effects if e.label not in have]
    before = path.nominal if path is not None else None
    sel = path.selection if path is not None else None
    final = None
    if path is not None and path.description is not None and path.description.accepted:
        final = path.description.fit
    elif sel is not None:
        final = sel.final
    details: dict[str, Any] = {
        "path": None if path is None else path.to_dict(),
        "command_driven": None if command is None else command.to_dict(),
    }
    moved: Mapping[str, tuple[Estimate, Estimate]] = {}
    if estimate_before is not None and estimate_after is not None:
        moved = moved_parameters(estimate_before.parameters, estimate_after.parameters)
    more: list[str] = []
    if path is not None:
        more += path.report()
    if command is not None:
        more += command.report().splitlines()
    return DiscoveryReport(
        "tractor_trailer",
        BASELINE,
        tuple(effects),
        before,
        adequacy,
        sel.base.heldout_sse if sel is not None else math.nan,
        final.heldout_sse if final is not None else math.nan,
        _remaining(path, adequacy),
        _alternatives(path, command),
        tuple(c.to_dict() for c in command.confounds) if command is not None else (),
        moved,
        _notes(command, notes),
        details,
        "ok" if (path is not None and path.status == "ok") or command is not None else "not_run",
        more=tuple(more),
    )
