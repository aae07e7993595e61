"""Model-mismatch discovery for arms: which catalogue term did the log's model leave out?

Catalogue: ``coulomb_friction``, ``coulomb_friction_smooth`` (its alternative with a 0.1 rad/s
velocity scale: when the model holds one, the other is tried *in its place*), ``viscous_friction``,
``torque_offset`` (per joint) and ``payload_mass`` (a point mass at the tool point). The baseline
is the model the log declares (its ``logcal`` metadata ``model_terms``; without one, the rigid
body alone). Forward selection: each term not in the model is added in turn, fitted on the first
60 % (momentum windows, WLS with Newey-West intervals) and judged on the last 40 % (held-out
torque RMS). A term is named only when
some coefficient's 95 % interval excludes 0 *and* the held-out RMS falls by at least
``MIN_IMPROVEMENT``; the best such term joins the model and the rest are tried again.

A payload changes only the last link's base parameters, so against a fitted rigid body it is
absorbed, not seen: it is tested only against a nominal rigid body (``nominal``: the link
parameters the log declares), and reported as untestable otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from calib.errors import CalibError
from calib.manipulator.design import ALTERNATIVES, Term, make_design
from calib.manipulator.identify import IdentifyConfig, fit_holdout
from calib.manipulator.model import ArmModel
from calib.manipulator.rows import compute_regressors
from calib.manipulator.signals import JointSignals
from calib.results import Estimate

__all__ = ["CATALOGUE", "MIN_IMPROVEMENT", "ArmDiscovery", "EffectFinding", "discover_arm"]

Array = NDArray[np.float64]

CATALOGUE: tuple[Term, ...] = (
    Term.COULOMB,
    Term.COULOMB_SMOOTH,
    Term.VISCOUS,
    Term.OFFSET,
    Term.PAYLOAD,
)
MIN_IMPROVEMENT = 0.05
"""Relative fall of the held-out torque RMS a term must bring to be named."""


@dataclass(frozen=True)
class EffectFinding:
    """One catalogue term tried: its fitted coefficients, held-out RMS before/after (N*m), and
    the term it was tried in place of (``replaces``), if any."""

    effect: str
    estimates: list[Estimate]
    rms_before: float
    rms_after: float
    excludes_null: bool
    named: bool
    replaces: str | None = None

    @property
    def improvement(self) -> float:
        return 1.0 - self.rms_after / self.rms_before if self.rms_before > 0 else 0.0

    def to_dict(self) -> dict[str, object]:
        return {
            "effect": self.effect,
            "named": self.named,
            "excludes_null": self.excludes_null,
            "replaces": self.replaces,
            "heldout_rms_before": self.rms_before,
            "heldout_rms_after": self.rms_after,
            "improvement": self.improvement,
            "parameters": [e.to_dict() for e in self.estimates],
        }


@dataclass(frozen=True)
class ArmDiscovery:
    """Discovery's result: the baseline, the named terms (in order), every trial, notes."""

    baseline: tuple[str, ...]
    nominal: bool
    named: list[EffectFinding]
    trials: list[EffectFinding]
    untestable: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        return {
            "baseline": list(self.baseline),
            "baseline_rigid_body": "nominal" if self.nominal else "fitted",
            "named": [f.effect for f in self.named],
            "findings": [f.to_dict() for f in self.named],
            "trials": [f.to_dict() for f in self.trials],
            "untestable": list(self.untestable),
        }

    def report(self) -> list[str]:
        base = ", ".join(self.baseline) or "rigid body only"
        lines = [
            f"Discovery (baseline: {base}; rigid body {'nominal' if self.nominal else 'fitted'})"
        ]
        if not self.named:
            lines.append("  no catalogue term improves the held-out fit: nothing named")
        for f in self.named:
            instead = f" (in place of {f.replaces})" if f.replaces else ""
            lines.append(
                f"  {f.effect}{instead}: held-out RMS {f.rms_before:.4g} -> {f.rms_after:.4g} N·m "
                f"({100 * f.improvement:.0f} % lower)"
            )
            lines += ["    " + e.report() for e in f.estimates]
        lines += [f"  {u}" for u in self.untestable]
        return lines


def _fit(
    model: ArmModel,
    sig: JointSignals,
    terms: tuple[Term, ...],
    nominal: Array | None,
    cfg: IdentifyConfig,
) -> tuple[float, dict[Term, list[Estimate]]]:
    design = make_design(model, terms, rigid=nominal is None, fixed_rigid=nominal)
    reg = compute_regressors(design, sig)
    w, hold = fit_holdout(reg, cfg)
    per_term: dict[Term, list[Estimate]] = {}
    names, units = design.names, design.units
    for t in terms:
        ests = []
        for k in design.term_slice(t):
            v, s = float(w.theta[k]), float(w.std[k])
            ok = bool(w.identifiable[k]) and np.isfinite(s)
            ests.append(
                Estimate(
                    names[k],
                    v,
                    s if ok else float("nan"),
                    (v - 1.96 * s, v + 1.96 * s) if ok else (float("nan"), float("nan")),
                    identifiable=ok,
                    unit=units[k],
                )
            )
        per_term[t] = ests
    return hold.pooled_rms, per_term


def discover_arm(
    model: ArmModel,
    sig: JointSignals,
    declared: tuple[Term, ...] = (),
    nominal: Array | None = None,
    config: IdentifyConfig | None = None,
) -> ArmDiscovery:
    """Forward selection over the catalogue against the declared model (see module docstring).

    ``sig`` are prepared signals (:func:`calib.manipulator.signals.prepare_signals`);
    ``nominal`` the full rigid-body parameters the log declares, or None.
    """
    cfg = config or IdentifyConfig()
    current = tuple(t for t in declared if t in CATALOGUE)
    untestable: list[str] = []
    candidates = [t for t in CATALOGUE if t not in current]
    if nominal is None and Term.PAYLOAD in candidates:
        candidates.remove(Term.PAYLOAD)
        untestable.append(
            "payload_mass: not testable without nominal link parameters (a payload only "
            "changes the last link's base parameters, which are fitted)"
        )
    rms0, _ = _fit(model, sig, current, nominal, cfg)
    named: list[EffectFinding] = []
    trials: list[EffectFinding] = []
    while candidates:
        best: EffectFinding | None = None
        best_terms = current
        for t in candidates:
            alt = ALTERNATIVES.get(t)
            swap = alt if alt in current else None
            trial = (*(x for x in current if x is not swap), t)
            try:
                rms, per = _fit(model, sig, trial, nominal, cfg)
            except (CalibError, np.linalg.LinAlgError) as err:
                untestable.append(f"{t}: {err}")
                continue
            ests = per[t]
            excl = any(e.identifiable and not (e.ci95[0] <= 0 <= e.ci95[1]) for e in ests)
            f = EffectFinding(str(t), ests, rms0, rms, excl, False, str(swap) if swap else None)
            trials.append(f)
            ok = excl and f.improvement >= MIN_IMPROVEMENT
            if ok and (best is None or f.rms_after < best.rms_after):
                best, best_terms = f, trial
        if best is None:
            break
        best = replace(best, named=True)
        named.append(best)
        term = Term(best.effect)
        current = best_terms
        gone = {term, ALTERNATIVES.get(term)} if best.replaces else {term}
        candidates = [t for t in candidates if t not in gone]
        rms0 = best.rms_after
    return ArmDiscovery(
        tuple(str(t) for t in declared), nominal is not None, named, trials, untestable
    )
