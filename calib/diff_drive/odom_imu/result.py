"""The odometry + IMU analysis' result: the gain and what it depends on, the GPS scale,
adequacy and discovery, as JSON (``to_dict``) and as the report's lines.

The gain it recommends (:meth:`OdomImuResult.recommended_gain`) is the one of the model that
ends discovery: a constant when that explains the log, the turn-weighted mean of the gain law
when the law explains it, and otherwise no value at all but the range the data allow (the
law's gains over the log, or the constant gain's widened interval), never a number with an
interval open to infinity."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from calib.adequacy import Adequacy
from calib.diff_drive.odom_imu.explain import Explained
from calib.diff_drive.odom_imu.windows import WINDOW_S
from calib.discovery import EffectKind, Selection
from calib.results import Estimate, json_safe

__all__ = ["OdomImuResult", "allowed_range"]


@dataclass(frozen=True)
class OdomImuResult:
    """The odometry + IMU analysis: ``gain`` (odometry / gyro yaw rate), the effective track
    when a geometric one is known, the gyro bias, the gain by turn-rate and speed bins, the GPS
    distance scale, adequacy and discovery."""

    gain: Estimate
    bias: Estimate
    lag_s: float
    effective_track: Estimate | None
    by_turn_rate: list[dict[str, float]]
    by_speed: list[dict[str, float]]
    distance_scale: Estimate | None
    adequacy: Adequacy
    selection: Selection | None
    n_windows: int
    notes: list[str] = field(default_factory=list)
    explained: Explained | None = None
    """The described residual and the final gain law (None: discovery did not run)."""

    @property
    def named(self) -> list[str]:
        """The catalogue effects of the model discovery ends with."""
        if self.explained is not None:
            return [
                e.id
                for e in self.explained.final.effects
                if str(e.kind) != str(EffectKind.DESCRIBED)
            ]
        return [] if self.selection is None else [e.id for e in self.selection.accepted]

    @property
    def final_adequacy(self) -> Adequacy:
        """The adequacy of the model discovery ends with (the constant gain's without one)."""
        law = None if self.explained is None else self.explained.law
        return self.adequacy if law is None else law.adequacy

    def recommended_gain(self, under_law: bool = True) -> Estimate:
        """The yaw-rate gain to report (module docstring); ``under_law`` False: the constant
        gain's, as reported before discovery."""
        law = None if self.explained is None or not under_law else self.explained.law
        if law is not None:
            if law.explains and law.mean_gain.identifiable:
                return law.mean_gain
            worst = _worst(law.adequacy)
            return Estimate(
                "yaw_rate_gain",
                math.nan,
                math.nan,
                (law.lowest, law.highest),
                False,
                "1",
                f"the gain varies over this log as {law.formula}, from "
                + allowed_range(Estimate("g", math.nan, math.nan, (law.lowest, law.highest)))
                + " over the windows that turn; no single value holds"
                + (f" (the model with it leaves {worst})" if worst else ""),
            )
        g = self.gain
        if g.identifiable:
            return g
        lo, hi = g.ci95
        allowed = allowed_range(g)
        worst = _worst(self.adequacy)
        return Estimate(
            "yaw_rate_gain",
            math.nan,
            math.nan,
            (lo, hi),
            False,
            "1",
            "a constant gain does not explain this log"
            + (f" ({worst})" if worst else "")
            + f"; the data allow {allowed}",
        )

    def law_parameters(self) -> dict[str, Estimate]:
        """The final model's effect parameters by ``id.param`` (described terms left out), when
        the final model explains the log (otherwise they are discovery's findings, not a
        calibration: the report shows them there)."""
        if self.explained is None or self.explained.law is None or not self.explained.law.explains:
            return {}
        fit = self.explained.law.fit
        out: dict[str, Estimate] = {}
        for e in fit.effects:
            if str(e.kind) == str(EffectKind.DESCRIBED):
                continue
            for n, est in fit.effect_parameters.get(e.key, {}).items():
                out[f"{e.id}.{n}"] = Estimate(
                    f"{e.id}.{n}",
                    est.value,
                    est.std,
                    est.ci95,
                    est.identifiable,
                    est.unit,
                    est.note,
                )
        slow = self.explained.law.at_slow_turn
        if slow is not None:
            out[slow.name] = slow
        return out

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "gain": self.gain.to_dict(),
                "gyro_bias": self.bias.to_dict(),
                "lag_s": self.lag_s,
                "effective_track": None
                if self.effective_track is None
                else self.effective_track.to_dict(),
                "gain_by_turn_rate": self.by_turn_rate,
                "gain_by_speed": self.by_speed,
                "distance_scale_gps": None
                if self.distance_scale is None
                else self.distance_scale.to_dict(),
                "windows": self.n_windows,
                "named": self.named,
                "selection": None if self.selection is None else self.selection.to_dict(),
                "law": None
                if self.explained is None or self.explained.law is None
                else self.explained.law.to_dict(),
                "description": None
                if self.explained is None or self.explained.description is None
                else self.explained.description.to_dict(),
                "notes": self.notes,
            }
        )

    def summary_lines(self) -> list[str]:
        """The gain, its dependence on turn rate, the GPS scale: the robot's report part."""
        g = self.recommended_gain()
        said = (
            f"{g.value:.4f} ± {g.std:.2g} [95 %: {g.ci95[0]:.4f}, {g.ci95[1]:.4f}]"
            if g.identifiable
            else f"not determined ({g.note})"
        )
        lines = [
            "Wheel odometry against the gyro (no encoder angles, no ground truth: radii not "
            "determined):",
            f"  yaw-rate gain (odometry / gyro) {said} over {self.n_windows} windows of "
            f"{WINDOW_S:g} s; gyro bias {self.bias.value:+.4f} rad/s; lag {self.lag_s:+.3f} s",
        ]
        if self.explained is not None and self.explained.law is not None:
            lines += [f"  {x}" for x in self.explained.law.lines()]
        if self.effective_track is not None:
            lines.append("  " + self.effective_track.report())
        if self.by_turn_rate:
            lines.append(
                "  gain by |turn rate|: "
                + ", ".join(
                    f"{b['lo']:.2g}-{b['hi']:.2g} rad/s: {b['gain']:.3g} ± {b['std']:.2g}"
                    for b in self.by_turn_rate
                )
            )
        if self.by_speed:
            lines.append(
                "  gain by speed: "
                + ", ".join(
                    f"{b['lo']:.2g}-{b['hi']:.2g} m/s: {b['gain']:.3g} ± {b['std']:.2g}"
                    for b in self.by_speed
                )
            )
        if self.distance_scale is not None:
            lines.append("  " + self.distance_scale.report())
        lines += [f"  {n}" for n in self.notes]
        return lines

    def report(self) -> list[str]:
        """Discovery's lines (the report's model-mismatch part)."""
        if self.selection is None:
            return ["Discovery: nothing tested."]
        acc = self.selection.accepted
        lines = [
            "Discovery: "
            + (
                ", ".join(e.key for e in acc)
                if acc
                else "no catalogued effect improves the held-out fit"
            )
        ]
        for e in acc:
            for n, p in self.selection.final.effect_parameters.get(e.key, {}).items():
                lines.append(f"  {e.key} {n} = {p.value:.4g} ± {p.std:.2g} {p.unit}: {e.physics}")
        b, a = self.selection.base.heldout_sse, self.selection.final.heldout_sse
        if acc and math.isfinite(b) and math.isfinite(a):
            lines.append(f"  held-out sum of squares (noise units) {b:.4g} -> {a:.4g}")
        lines += [f"  {c.note}" for c in self.selection.confounds]
        return lines


def _worst(a: Adequacy) -> str:
    """'channel Nx its noise floor' of the worst channel, or ''."""
    if not a.channels:
        return ""
    c = max(a.channels, key=lambda c: c.judged_ratio)
    return f"{c.channel} {c.judged_ratio:.2g}x its noise floor"


def allowed_range(e: Estimate) -> str:
    """``e``'s interval in words ("1.13 to 7.05", "1.13 upward (no upper bound)")."""
    lo, hi = e.ci95
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{lo:.4g} to {hi:.4g}"
    if math.isfinite(lo):
        return f"{lo:.4g} upward (no upper bound)"
    if math.isfinite(hi):
        return f"up to {hi:.4g} (no lower bound)"
    return "any value"
