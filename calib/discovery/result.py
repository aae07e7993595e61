"""Result types of model-mismatch discovery."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.discovery.diagnostics import UNITS, MismatchRegion
from calib.discovery.sparse import SparseResidualModel
from calib.results import json_safe

__all__ = ["BASELINE_DESCRIPTIONS", "DiscoveryResult", "EffectFit"]

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
class EffectFit:
    """An accepted effect: fitted parameters with 95 % intervals and the evidence.

    ``rms_before``/``rms_after``: held-out RMS per output (omega rad/s, psi rad) of the model
    without and with this effect (the round in which it was accepted); ``delta_bic`` the BIC
    change of that round (negative favours the effect); ``alternatives`` other effects that
    passed the same round within 10 BIC units (the log cannot tell them apart well).
    """

    id: str
    target: str | None
    parameters: Mapping[str, float]
    std: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    units: Mapping[str, str]
    channels: tuple[str, ...]
    rms_before: Mapping[str, float]
    rms_after: Mapping[str, float]
    delta_bic: float
    explanation: str
    alternatives: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        return self.id if self.target is None else f"{self.id}({self.target})"

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
    the final model; ``residuals``: "t_ns" and "<output>_before"/"<output>_after" (recorded -
    modelled) on the aligned grid; ``diagnostics``: bins, whiteness, cross-correlations and the
    selection rounds.
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

    def effect(self, effect_id: str, target: str | None = None) -> EffectFit | None:
        """The accepted effect with ``effect_id`` (and ``target`` if given), else None."""
        for e in self.effects:
            if e.id == effect_id and (target is None or e.target == target):
                return e
        return None

    def report(self) -> str:
        lines = [f"Baseline ({self.baseline}): {BASELINE_DESCRIPTIONS[self.baseline]}."]
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
        if self.residual_model is not None:
            lines.append("Beyond the catalogue: " + self.residual_model.describe() + ".")
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
                "residual_model": None
                if self.residual_model is None
                else self.residual_model.to_dict(),
                "diagnostics": dict(self.diagnostics),
            }
        )
