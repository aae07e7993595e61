"""Result types of model-mismatch discovery."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.discovery.sparse import SparseResidualModel
from calib.results import Estimate, json_safe
from calib.tractor_trailer.discovery.diagnostics import UNITS, MismatchRegion
from calib.tractor_trailer.discovery.effects.base import SensorCorrections
from calib.tractor_trailer.discovery.windows import DataWindows

__all__ = [
    "BASELINE_DESCRIPTIONS",
    "AlternativeExplanation",
    "DiscoveryResult",
    "EffectFit",
    "ExplanationFit",
    "JointFit",
    "LengthConfound",
    "SensorCorrections",
    "StepFailure",
]

BASELINE_DESCRIPTIONS = {
    "steady": (
        "the patent's steady-state model: curvature = command, yaw rate = v kappa_cmd, joint "
        "angle on sin(psi) = kappa (L2 + L1 cos psi), ideal sensors and clocks"
    ),
    "transient": (
        "transient off-axle kinematics: curvature = command, yaw rate = v kappa_cmd, "
        "d psi/ds = kappa (1 + L1/L2 cos psi) - sin(psi)/L2, ideal sensors and clocks"
    ),
}


@dataclass(frozen=True)
class AlternativeExplanation:
    """Another explanation of the same misfit that this log barely tells from the reported one.

    ``reported``: labels of the reported effects it stands for; ``alternative``: labels of its
    effects (one or more); ``parameters``/``ci95``: their fitted values and 95 % intervals per
    label; ``delta_bic``: BIC(alternative) - BIC(reported) on the training blocks (positive
    favours the reported one; within ``confirm.EQUIVALENCE_MARGIN`` = 10 the two count as
    equivalent and the one with fewer effects is reported); ``rule``: which known equivalence
    (or "same_round": another candidate of the selection round in which the effect was
    accepted); ``note``: why they look alike and why the reported one was chosen.
    """

    reported: tuple[str, ...]
    alternative: tuple[str, ...]
    parameters: Mapping[str, Mapping[str, float]]
    ci95: Mapping[str, Mapping[str, tuple[float, float]]]
    delta_bic: float
    rule: str
    note: str

    @property
    def label(self) -> str:
        return " + ".join(self.alternative)

    def report(self) -> str:
        pars = "; ".join(
            f"{k}: "
            + ", ".join(
                f"{n} = {v:.4g} [{self.ci95[k][n][0]:.4g}, {self.ci95[k][n][1]:.4g}]"
                for n, v in p.items()
            )
            for k, p in self.parameters.items()
        )
        return (
            f"{' + '.join(self.reported)} could also be {self.label} ({pars}; BIC "
            f"{self.delta_bic:+.1f}): {self.note}"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "reported": list(self.reported),
                "alternative": list(self.alternative),
                "label": self.label,
                "parameters": {k: dict(v) for k, v in self.parameters.items()},
                "ci95": {k: {n: list(ci) for n, ci in v.items()} for k, v in self.ci95.items()},
                "delta_bic": self.delta_bic,
                "rule": self.rule,
                "note": self.note,
            }
        )


@dataclass(frozen=True)
class ExplanationFit:
    """One explanation of a confound: its effects fitted jointly with L1, L2 on every valid
    row (the fit ``JointFit`` is for the reported one). ``effects``: labels (empty: the
    baseline alone); ``parameters``/``std``/``ci95``: L1 and L2 (m); ``effect_parameters``:
    the effects' values; ``corrections``: what it says about the joint-angle sensor."""

    effects: tuple[str, ...]
    parameters: Mapping[str, float]
    std: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    effect_parameters: Mapping[str, Mapping[str, float]]
    effect_ci95: Mapping[str, Mapping[str, tuple[float, float]]]
    corrections: SensorCorrections

    @property
    def label(self) -> str:
        return " + ".join(self.effects) or "no effect"

    def lengths(self) -> str:
        return ", ".join(
            f"{k} = {v:.4g} m [{self.ci95[k][0]:.4g}, {self.ci95[k][1]:.4g}]"
            for k, v in self.parameters.items()
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "effects": list(self.effects),
                "label": self.label,
                "parameters": dict(self.parameters),
                "std": dict(self.std),
                "ci95": {k: list(v) for k, v in self.ci95.items()},
                "effect_parameters": {k: dict(v) for k, v in self.effect_parameters.items()},
                "effect_ci95": {
                    k: {n: list(ci) for n, ci in v.items()} for k, v in self.effect_ci95.items()
                },
                "corrections": self.corrections.to_dict(),
            }
        )


@dataclass(frozen=True)
class LengthConfound:
    """Two explanations this log does not tell apart that imply different link lengths, or
    different corrections of the joint-angle sensor (which a fit of L1, L2 along the measured
    path would take in). An estimate of L1, L2 must then span both (refit with each side's
    ``corrections`` and take the union of the intervals) or be "not determined"; it may not
    take one side's. ``calib.tractor_trailer.discovery.sensor_effects_for_fit`` says which.

    ``rule``: the equivalence an effect declares (``Effect.equivalents``: with other effects,
    or with the link lengths, e.g. "joint_angle_gain_vs_link_lengths", a gain of the
    joint-angle sensor that L1 + L2 absorb: at small angles psi ~ kappa (L1 + L2)), or
    "same_round"; ``reported``/``alternative``: the two
    explanations (``reported`` the one in ``DiscoveryResult.effects``); ``delta_bic``:
    BIC(alternative) - BIC(reported) on the training blocks (NaN where not compared);
    ``why``: why the log does not tell them apart (within ``EQUIVALENCE_MARGIN`` BIC, held-out
    errors that differ immaterially, or a parameter the fit cannot pin); ``lengths_differ``:
    L1 or L2 differ by more than one combined standard error; ``corrections_differ``: the
    sides correct the joint-angle sensor differently.
    """

    rule: str
    reported: ExplanationFit
    alternative: ExplanationFit
    delta_bic: float
    why: str
    lengths_differ: bool
    corrections_differ: bool

    def span(self) -> dict[str, tuple[float, float]]:
        """Union of the two sides' 95 % intervals of L1 and L2 (m), from discovery's fits."""
        out = {}
        for k in self.reported.ci95:
            a, b = self.reported.ci95[k], self.alternative.ci95.get(k, self.reported.ci95[k])
            out[k] = (min(a[0], b[0]), max(a[1], b[1]))
        return out

    def report(self) -> str:
        return (
            f"{self.reported.label} ({self.reported.lengths()}) or {self.alternative.label} "
            f"({self.alternative.lengths()}): {self.why}"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "rule": self.rule,
                "reported": self.reported.to_dict(),
                "alternative": self.alternative.to_dict(),
                "delta_bic": self.delta_bic,
                "why": self.why,
                "lengths_differ": self.lengths_differ,
                "corrections_differ": self.corrections_differ,
                "span": {k: list(v) for k, v in self.span().items()},
            }
        )


@dataclass(frozen=True)
class JointFit:
    """L1, L2 fitted jointly with the accepted effects: the model the result stands on.

    ``baseline``: "steady" or "transient"; ``effects``: labels of the effects in the model
    (empty: the baseline alone); ``parameters``/``std``/``ci95``: L1 and L2 (m), 95 % intervals
    value +/- 1.96 std (Gauss-Newton Fisher information, residual variance from the fit and
    inflated for residual autocorrelation); ``covariance``: 2x2 of (L1, L2) in m^2;
    ``effect_parameters``: the effects' values in the same fit; ``n_samples``: fitting-grid
    rows used; ``fit_rate_hz``: that grid's rate.
    """

    baseline: str
    effects: tuple[str, ...]
    parameters: Mapping[str, float]
    std: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    covariance: tuple[tuple[float, float], tuple[float, float]]
    effect_parameters: Mapping[str, Mapping[str, float]]
    n_samples: int
    fit_rate_hz: float

    @property
    def model(self) -> str:
        """E.g. "transient + actuator_delay + clock_offset(hitch)"."""
        return " + ".join((self.baseline, *self.effects))

    def report(self) -> str:
        return f"Joint fit ({self.model}): " + ", ".join(
            f"{k} = {v:.4g} m [95 %: {self.ci95[k][0]:.4g}, {self.ci95[k][1]:.4g}]"
            for k, v in self.parameters.items()
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "model": self.model,
                "baseline": self.baseline,
                "effects": list(self.effects),
                "parameters": dict(self.parameters),
                "std": dict(self.std),
                "ci95": {k: list(v) for k, v in self.ci95.items()},
                "covariance": [list(r) for r in self.covariance],
                "units": {"L1": "m", "L2": "m"},
                "effect_parameters": {k: dict(v) for k, v in self.effect_parameters.items()},
                "n_samples": self.n_samples,
                "fit_rate_hz": self.fit_rate_hz,
            }
        )


@dataclass(frozen=True)
class StepFailure:
    """A discovery step that failed: its name and the error, in words."""

    step: str
    reason: str

    def to_dict(self) -> dict[str, str]:
        return {"step": self.step, "reason": self.reason}


@dataclass(frozen=True)
class EffectFit:
    """An accepted effect: fitted parameters with 95 % intervals and the evidence.

    ``estimates``: each parameter by name as an :class:`calib.results.Estimate` (value, std,
    95 % interval, unit); ``parameters``, ``std``, ``ci95`` and ``units`` are views of it.
    ``rms_before``/``rms_after``: held-out RMS per output (omega rad/s, psi rad) of the final
    model without this effect (the others kept and refitted) and with it; ``delta_bic`` the
    BIC change of adding it to the others (negative favours the effect); ``alternatives``
    labels of explanations the log barely tells from this one (details in
    ``DiscoveryResult.alternatives``; a set of effects is joined with " + "); ``kind``: the
    effect's :class:`calib.adequacy.EffectKind` ("sensor", "actuator", "dynamics", "clock"),
    from its catalogue entry.
    """

    id: str
    target: str | None
    estimates: Mapping[str, Estimate]
    channels: tuple[str, ...]
    rms_before: Mapping[str, float]
    rms_after: Mapping[str, float]
    delta_bic: float
    explanation: str
    alternatives: tuple[str, ...] = ()
    kind: str = ""

    @property
    def label(self) -> str:
        return self.id if self.target is None else f"{self.id}({self.target})"

    @property
    def parameters(self) -> dict[str, float]:
        """Parameter values by name."""
        return {k: e.value for k, e in self.estimates.items()}

    @property
    def std(self) -> dict[str, float]:
        """Standard errors by name."""
        return {k: e.std for k, e in self.estimates.items()}

    @property
    def ci95(self) -> dict[str, tuple[float, float]]:
        """95 % intervals by name."""
        return {k: e.ci95 for k, e in self.estimates.items()}

    @property
    def units(self) -> dict[str, str]:
        """Units by name."""
        return {k: e.unit for k, e in self.estimates.items()}

    def improvement(self, channel: str) -> float:
        """Relative fall of the held-out RMS of ``channel`` (0.6 = 60 % lower)."""
        return 1.0 - self.rms_after[channel] / self.rms_before[channel]

    def report(self) -> str:
        pars = ", ".join(
            f"{k} = {v:.4g} {self.units[k]} [95 %: {self.ci95[k][0]:.4g}, {self.ci95[k][1]:.4g}]"
            for k, v in self.parameters.items()
        )
        fits = "; ".join(
            f"held-out {c} RMS {self.rms_before[c]:.3g} -> {self.rms_after[c]:.3g} {UNITS[c]} "
            f"({-100 * self.improvement(c):+.0f} %)"
            for c in self.channels
            if c in self.rms_before
        )
        head = f"{self.label}: {pars}"
        if self.alternatives:
            head += f" (this log barely tells it from {', '.join(self.alternatives)})"
        return f"{head}\n    {self.explanation}\n    {fits}; dBIC {self.delta_bic:.1f}"

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "id": self.id,
                "target": self.target,
                "label": self.label,
                "kind": self.kind,
                "parameters": dict(self.parameters),
                "std": dict(self.std),
                "ci95": {k: list(v) for k, v in self.ci95.items()},
                "units": dict(self.units),
                "channels": list(self.channels),
                "rms_before": dict(self.rms_before),
                "rms_after": dict(self.rms_after),
                "delta_bic": self.delta_bic,
                "explanation": self.explanation,
                "alternatives": list(self.alternatives),
            }
        )


@dataclass(frozen=True)
class DiscoveryResult:
    """What discovery found in one log.

    ``baseline``: "steady" or "transient"; ``rms_baseline``/``rms_final``: held-out RMS per
    output of the baseline and of the final model; ``link_lengths``: L1, L2 (m) refitted with
    the final model (the values of ``joint_fit``); ``joint_fit``: L1, L2 with intervals and
    covariance from the final joint fit and the model it came from (baseline + accepted
    effects; None if that fit failed); ``alternatives``: explanations the log barely tells
    from the reported effects; ``confounds``: the pairs of explanations the log does not
    tell apart that imply different link lengths or joint-angle corrections, each with the
    L1, L2 it implies (an estimate must span them: ``sensor_effects_for_fit``);
    ``residuals``: "t_ns" and "<output>_before"/"<output>_after" (recorded - modelled) on the
    aligned grid; ``windows``: the part of a long log discovery looked at (None: all of it);
    ``diagnostics``: bins, whiteness, cross-correlations, the selection rounds and the
    confirmation ("confirmation": dropped effects and equivalence swaps).

    ``status``: "ok"; "partial" (a step failed, listed in ``failures``; the rest is
    reported); "not_run" (the log gives discovery nothing to work on; ``reason`` says why).
    """

    baseline: str
    regions: list[MismatchRegion]
    effects: list[EffectFit]
    rms_baseline: Mapping[str, float]
    residual_model: SparseResidualModel | None
    diagnostics: Mapping[str, Any]
    residuals: Mapping[str, NDArray[np.float64]] = field(repr=False, default_factory=dict)
    rms_final: Mapping[str, float] = field(default_factory=dict)
    link_lengths: Mapping[str, float] = field(default_factory=dict)
    joint_fit: JointFit | None = None
    alternatives: list[AlternativeExplanation] = field(default_factory=list)
    confounds: list[LengthConfound] = field(default_factory=list)
    status: str = "ok"
    reason: str | None = None
    failures: list[StepFailure] = field(default_factory=list)
    windows: DataWindows | None = None

    @classmethod
    def not_run(cls, baseline: str, failures: list[StepFailure]) -> DiscoveryResult:
        """The result when discovery could not work on the log (``status`` "not_run")."""
        return cls(
            baseline=baseline,
            regions=[],
            effects=[],
            rms_baseline={},
            residual_model=None,
            diagnostics={},
            status="not_run",
            reason=failures[0].reason if failures else None,
            failures=failures,
        )

    def effect(self, effect_id: str, target: str | None = None) -> EffectFit | None:
        """The accepted effect with ``effect_id`` (and ``target`` if given), else None."""
        for e in self.effects:
            if e.id == effect_id and (target is None or e.target == target):
                return e
        return None

    def report(self) -> str:
        if self.status == "not_run":
            return f"Model-mismatch discovery did not run: {self.reason}"
        lines = [f"Baseline ({self.baseline}): {BASELINE_DESCRIPTIONS[self.baseline]}."]
        if self.windows is not None:
            lines.append(self.windows.note())
        lines.append(
            "Held-out RMS of the baseline: "
            + ", ".join(f"{c} {v:.3g} {UNITS[c]}" for c, v in self.rms_baseline.items())
        )
        if self.regions:
            lines.append(f"Where the baseline misses ({len(self.regions)} region(s)):")
            lines += ["  " + r.report() for r in self.regions[:5]]
        if not self.effects and self.residual_model is None:
            lines.append(
                "No effect beyond the baseline: no candidate improved the held-out fit "
                "materially with strong, constant evidence; the log holds nothing the baseline "
                "leaves out."
            )
        elif not self.effects:
            lines.append(
                "No catalogued effect explains the misfit (none improved the held-out fit "
                "materially with strong, constant evidence), but the residual is not noise:"
            )
        else:
            lines.append(f"Left out of the baseline ({len(self.effects)} effect(s)):")
            lines += [f"  {i + 1}. " + e.report() for i, e in enumerate(self.effects)]
            lines.append(
                "With them the held-out RMS is "
                + ", ".join(
                    f"{c} {self.rms_final[c]:.3g} {UNITS[c]} "
                    f"({-100 * (1 - self.rms_final[c] / self.rms_baseline[c]):+.0f} %)"
                    for c in self.rms_final
                )
                + "."
            )
        if self.alternatives:
            lines.append("Equivalent explanations this log barely tells apart:")
            lines += ["  - " + a.report() for a in self.alternatives]
        if self.effects and self.joint_fit is not None:
            lines.append(self.joint_fit.report() + ".")
        if self.confounds:
            lines.append(
                "Confounds: explanations this log does not tell apart that imply different "
                "link lengths (an estimate of L1, L2 must span them or is not determined):"
            )
            lines += ["  - " + c.report() for c in self.confounds]
        if self.residual_model is not None:
            lines.append("Beyond the catalogue: " + self.residual_model.describe() + ".")
        if self.failures:
            lines.append(
                "Steps that failed (their part is missing): "
                + "; ".join(f"{f.step}: {f.reason}" for f in self.failures)
            )
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "baseline": self.baseline,
                "baseline_model": BASELINE_DESCRIPTIONS[self.baseline],
                "regions": [r.to_dict() for r in self.regions],
                "effects": [e.to_dict() for e in self.effects],
                "rms_baseline": dict(self.rms_baseline),
                "rms_final": dict(self.rms_final),
                "link_lengths": dict(self.link_lengths),
                "joint_fit": None if self.joint_fit is None else self.joint_fit.to_dict(),
                "alternatives": [a.to_dict() for a in self.alternatives],
                "confounds": [c.to_dict() for c in self.confounds],
                "status": self.status,
                "reason": self.reason,
                "failures": [f.to_dict() for f in self.failures],
                "residual_model": None
                if self.residual_model is None
                else self.residual_model.to_dict(),
                "diagnostics": dict(self.diagnostics),
                "windows": None if self.windows is None else self.windows.to_dict(),
            }
        )
