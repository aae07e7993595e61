"""The arm's discovery run: forward selection over the catalogue through the shared engine
(:func:`calib.discovery.select_effects`) with the arm's fitter, and its result (the named effects,
every trial, the confounds)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from calib.discovery import (
    BIC_MARGIN,
    MIN_HELDOUT_GAIN,
    Description,
    EffectSpec,
    ModelFit,
    Selection,
    heldout_gain,
    select_effects,
)
from calib.errors import CalibError
from calib.manipulator.design import Term
from calib.manipulator.discovery.catalogue import MAX_COMPLIANCE_JOINTS, arm_catalogue
from calib.manipulator.discovery.described import describe_arm
from calib.manipulator.discovery.fitter import ArmFit, ArmFitter
from calib.manipulator.discovery.hooks import Array, hook
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.model import ArmModel
from calib.manipulator.signals import JointSignals
from calib.results import Estimate

__all__ = [
    "ArmDiscovery",
    "EffectFinding",
    "discover_arm",
    "discovery_from_selection",
    "effect_estimates",
    "run_discovery",
]


@dataclass(frozen=True)
class EffectFinding:
    """One effect tried or named: its key, fitted parameters, held-out RMS before/after (N·m,
    pooled over joints), whether its intervals exclude the null, named or not, and the baseline
    term it was fitted in place of (``replaces``)."""

    effect: str
    estimates: list[Estimate]
    rms_before: float
    rms_after: float
    excludes_null: bool
    named: bool
    replaces: str | None = None
    delta_bic: float = math.nan
    key: str = ""

    @property
    def improvement(self) -> float:
        return 1.0 - self.rms_after / self.rms_before if self.rms_before > 0 else 0.0

    def to_dict(self) -> dict[str, object]:
        return {
            "effect": self.effect,
            "key": self.key,
            "named": self.named,
            "excludes_null": self.excludes_null,
            "replaces": self.replaces,
            "delta_bic": None if not math.isfinite(self.delta_bic) else self.delta_bic,
            "heldout_rms_before": self.rms_before,
            "heldout_rms_after": self.rms_after,
            "improvement": self.improvement,
            "parameters": [e.to_dict() for e in self.estimates],
        }


@dataclass(frozen=True)
class ArmDiscovery:
    """Discovery's result: the baseline, the named effects (in order), every trial, confounds,
    notes, and the shared engine's :class:`~calib.adequacy.Selection`."""

    baseline: tuple[str, ...]
    nominal: bool
    named: list[EffectFinding]
    trials: list[EffectFinding]
    untestable: list[str] = field(default_factory=list)
    selection: Selection | None = None
    confound_notes: list[str] = field(default_factory=list)
    description: Description | None = None
    """The residual model of what the selected effects leave (kept or not)."""
    dropped: tuple[str, ...] = ()
    """Keys of selected effects the kept description makes redundant (not named)."""
    final: ModelFit | None = None
    """The model discovery ends with (None: the selection's)."""

    @property
    def accepted(self) -> tuple[EffectSpec, ...]:
        return () if self.selection is None else self.selection.accepted

    @property
    def final_effects(self) -> tuple[EffectSpec, ...]:
        """The accepted catalogue effects, then the described one when it was kept."""
        d = self.description
        kept = tuple(e for e in self.accepted if e.key not in self.dropped)
        return (*kept, *((d.spec,) if d is not None and d.accepted else ()))

    def to_dict(self) -> dict[str, object]:
        return {
            "baseline": list(self.baseline),
            "baseline_rigid_body": "nominal" if self.nominal else "fitted",
            "named": [f.effect for f in self.named],
            "named_keys": [f.key for f in self.named],
            "findings": [f.to_dict() for f in self.named],
            "trials": [f.to_dict() for f in self.trials],
            "confounds": []
            if self.selection is None
            else [c.to_dict() for c in self.selection.confounds],
            "selection": None if self.selection is None else self.selection.to_dict(),
            "untestable": list(self.untestable),
            "residual_model": None if self.description is None else self.description.to_dict(),
            "dropped": list(self.dropped),
        }

    def report(self) -> list[str]:
        base = ", ".join(self.baseline) or "rigid body only"
        lines = [
            f"Discovery (baseline: {base}; rigid body {'nominal' if self.nominal else 'fitted'})"
        ]
        if not self.named:
            lines.append("  no catalogue effect improves the held-out fit: nothing named")
        for f in self.named:
            instead = f" (in place of {f.replaces})" if f.replaces else ""
            lines.append(
                f"  {f.key or f.effect}{instead}: held-out RMS {f.rms_before:.4g} -> "
                f"{f.rms_after:.4g} N·m ({100 * f.improvement:.0f} % lower)"
            )
            lines += ["    " + e.report() for e in f.estimates]
        lines += [f"  Confound: {c}" for c in self.confound_notes]
        lines += [f"  {u}" for u in self.untestable]
        return lines


def _pooled(mf: ModelFit) -> float:
    fit: ArmFit = mf.payload
    return float(np.sqrt(np.mean(fit.heldout_rms() ** 2)))


def discovery_from_selection(
    sel: Selection,
    baseline: tuple[Term, ...],
    nominal: bool,
    untestable: list[str],
    path: Sequence[ModelFit | None] = (),
    catalogue: Sequence[EffectSpec] = (),
) -> ArmDiscovery:
    """Turn the engine's selection into the arm's discovery result; ``path``: the fits of the
    accepted effects' prefixes (one per named effect, the last being ``sel.final``), for the
    held-out RMS after each (default: only the final one is known); ``catalogue``: the effects
    tried (for what each was fitted in place of; the accepted ones are known anyway)."""
    before = _pooled(sel.base)
    by_key = {e.key: e for e in (*catalogue, *sel.final.effects)}

    def replaces(key: str) -> str | None:
        e = by_key.get(key)
        return None if e is None else hook(e).replaces(baseline)

    trials = [
        EffectFinding(
            by_key[t.key].id if t.key in by_key else t.key.split("(")[0],
            list(sel.final.effect_parameters.get(t.key, {}).values()),
            before,
            math.nan,
            t.excludes_null,
            t.accepted,
            replaces(t.key),
            t.delta_bic,
            t.key,
        )
        for t in sel.tried
    ]
    named: list[EffectFinding] = []
    prev = before
    keys = sel.final.keys
    for i, key in enumerate(keys):
        fit = path[i] if i < len(path) else (sel.final if i == len(keys) - 1 else None)
        fit = sel.final if i == len(keys) - 1 else fit
        after = _pooled(fit) if fit is not None else math.nan
        dbic = next((t.delta_bic for t in sel.tried if t.key == key and t.accepted), math.nan)
        named.append(
            EffectFinding(
                by_key[key].id,
                list(sel.final.effect_parameters.get(key, {}).values()),
                prev,
                after,
                True,
                True,
                replaces(key),
                dbic,
                key,
            )
        )
        prev = after
    notes = [c.note for c in sel.confounds]
    return ArmDiscovery(
        tuple(str(t) for t in baseline), nominal, named, trials, untestable, sel, notes
    )


def run_discovery(
    fitter: ArmFitter,
    *,
    max_effects: int = 2,
    progress: Callable[[str], None] | None = None,
    residual_model: bool = True,
) -> ArmDiscovery:
    """Forward selection over the arm's catalogue through the shared engine, then the residual
    model of what the selected effects leave (``residual_model``;
    :mod:`calib.manipulator.discovery.described`)."""
    joints = fitter.model.joint_names
    untestable: list[str] = []
    if fitter.nominal is None:
        untestable.append(
            "payload_mass: not testable without nominal link parameters (a payload only "
            "changes the last link's base parameters, which are fitted; a payload picked up "
            "mid-log is looked for as a parameter change)"
        )
    if len(joints) > MAX_COMPLIANCE_JOINTS:
        untestable.append(
            f"joint_compliance: not tried on arms with more than {MAX_COMPLIANCE_JOINTS} joints "
            "(each joint's column needs the regressor along the whole log twice)"
        )
    cat = arm_catalogue(joints, fitter.baseline, nominal=fitter.nominal is not None)
    sel = select_effects(
        fitter, cat, max_effects=max_effects, explained=fitter.explained, progress=progress
    )
    if sel is None:
        raise CalibError("discovery: the baseline model could not be fitted")
    effects = sel.final.effects
    path: list[ModelFit | None] = [fitter(effects[: i + 1]) for i in range(len(effects) - 1)]
    path.append(sel.final)
    disc = discovery_from_selection(
        sel, fitter.baseline, fitter.nominal is not None, untestable, path, cat
    )
    if not residual_model:
        return disc
    if progress is not None:
        progress("discovery: residual model")
    d = describe_arm(fitter, sel.final, explained=fitter.explained(sel.final))
    if d is None or not d.accepted:
        return replace(disc, description=d)
    kept, final = _still_needed(fitter, sel.final.effects, d.spec, d.fit)
    dropped = tuple(e.key for e in sel.final.effects if e not in kept)
    return replace(disc, description=d, dropped=dropped, final=final)


def _still_needed(
    fitter: ArmFitter,
    effects: Sequence[EffectSpec],
    described: EffectSpec,
    fit: ModelFit,
) -> tuple[tuple[EffectSpec, ...], ModelFit]:
    """The selected ``effects`` a kept description leaves needed, and the final fit: each in
    turn (the last first) is left out while the model with the description is not worse without
    it by the selection's own rules (a held-out gain of ``MIN_HELDOUT_GAIN`` and a BIC margin):
    an effect the description makes redundant was a stand-in for it, not a name."""
    kept = list(effects)
    for e in reversed(effects):
        rest = tuple(x for x in kept if x is not e)
        without = fitter((*rest, described))
        if without is None:
            continue
        needed = heldout_gain(without, fit) >= MIN_HELDOUT_GAIN and fit.bic - without.bic < -(
            BIC_MARGIN
        )
        if not needed:
            kept, fit = list(rest), without
    return tuple(kept), fit


def discover_arm(
    model: ArmModel,
    sig: JointSignals,
    declared: tuple[Term, ...] = (),
    nominal: Array | None = None,
    config: IdentifyConfig | None = None,
    *,
    floors: Array | None = None,
    progress: Callable[[str], None] | None = None,
) -> ArmDiscovery:
    """Forward selection over the catalogue against the declared model (see module docstring).

    ``sig`` are prepared signals (:func:`calib.manipulator.signals.prepare_signals`);
    ``nominal`` the full rigid-body parameters the log declares, or None; ``floors`` the
    per-joint torque noise floors (default: estimated from the baseline's residual).
    """
    fitter = ArmFitter(model, sig, tuple(declared), nominal, config, floors)
    return run_discovery(fitter, progress=progress)


def effect_estimates(disc: ArmDiscovery) -> Mapping[str, Estimate]:
    """Every named effect's parameters, by name."""
    out: dict[str, Estimate] = {}
    for f in disc.named:
        for e in f.estimates:
            out[e.name] = e
    return out
