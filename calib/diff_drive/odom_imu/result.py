"""The odometry + IMU analysis' result: the gain and what it depends on, the GPS scale,
adequacy and discovery, as JSON (``to_dict``) and as the report's lines."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from calib.adequacy import Adequacy
from calib.diff_drive.odom_imu.windows import WINDOW_S
from calib.discovery import Selection
from calib.results import Estimate, json_safe

__all__ = ["OdomImuResult"]


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

    @property
    def named(self) -> list[str]:
        return [] if self.selection is None else [e.id for e in self.selection.accepted]

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
                "notes": self.notes,
            }
        )

    def summary_lines(self) -> list[str]:
        """The gain, its dependence on turn rate, the GPS scale: the robot's report part."""
        g = self.gain
        lines = [
            "Wheel odometry against the gyro (no encoder angles, no ground truth: radii not "
            "determined):",
            f"  yaw-rate gain (odometry / gyro) {g.value:.4f} ± {g.std:.2g} "
            f"[95 %: {g.ci95[0]:.4f}, {g.ci95[1]:.4f}] over {self.n_windows} windows of "
            f"{WINDOW_S:g} s"
            + ("" if g.identifiable else " (not determined)")
            + f"; gyro bias {self.bias.value:+.4f} rad/s; lag {self.lag_s:+.3f} s",
        ]
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
