"""Differential-drive discovery: does the log contradict the nominal model (equal wheel radii,
the nominal track)? Two effects are named, each only when (1) the 95 % bootstrap interval of
its size excludes the null and (2) allowing it improves the fit of held-out segments
(two-fold cross-validation over alternating blocks of segments, so neighbours that share slip
do not leak between folds):

* ``wheel_radius_asymmetry``: r_R / r_L - 1 (null 0); held out: the yaw change per segment;
* ``effective_track``: b / b_nominal - 1 (null 0, needs a nominal track); held out: the yaw
  change per segment with the fitted radii and the nominal vs fitted track. An effective track
  much wider than the geometric one is the signature of a skid-steer robot.

Quiet on clean logs: a false alarm needs both tests to fire by chance.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import LsqFit, segment_design, solve_rows
from calib.results import Estimate, json_safe

__all__ = ["DiffDriveDiscovery", "Finding", "discover"]

CV_BLOCK = 5
"""Segments per block of the two-fold cross-validation."""


@dataclass(frozen=True)
class Finding:
    """One effect tested: its size (relative, with interval), the held-out improvement
    (fraction of held-out squared heading error removed) and whether it is named."""

    name: str
    size: Estimate
    held_out_gain: float
    named: bool
    explanation: str

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "name": self.name,
                "size": self.size.to_dict(),
                "held_out_gain": self.held_out_gain,
                "named": self.named,
                "explanation": self.explanation,
            }
        )


@dataclass(frozen=True)
class DiffDriveDiscovery:
    """The effects tested on one log; ``named`` lists those the data call for."""

    findings: list[Finding] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def named(self) -> list[str]:
        return [f.name for f in self.findings if f.named]

    def to_dict(self) -> dict[str, Any]:
        return {
            "named": self.named,
            "findings": [f.to_dict() for f in self.findings],
            "notes": list(self.notes),
        }

    def report(self) -> list[str]:
        if not self.findings:
            return ["Discovery: nothing tested. " + " ".join(self.notes)]
        lines = [
            "Discovery: " + (", ".join(self.named) if self.named else "the nominal model fits")
        ]
        lines += [f"  {f.explanation}" for f in self.findings]
        lines += [f"  {n}" for n in self.notes]
        return lines


def _folds(n: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    block = (np.arange(n) // CV_BLOCK) % 2
    return np.flatnonzero(block == 0), np.flatnonzero(block == 1)


def _heading_sse(design: Any, rows: NDArray[np.intp], c_R: float, c_L: float) -> float:
    pred = design.dphi[rows] @ np.array([c_R, -c_L])
    return float(np.sum((design.dyaw[rows] - pred) ** 2))


def _cv_gains(
    runs: list[DriveRun], segment_s: float, b_nominal: float | None
) -> tuple[float, float]:
    """Held-out gains (fraction of squared heading error removed) of the asymmetry and of the
    fitted track; NaN where a fold cannot be fitted."""
    d = segment_design(runs, segment_s)
    n = len(d.segments)
    if n < 4 * CV_BLOCK:
        return np.nan, np.nan
    sse = {"sym": 0.0, "free": 0.0, "nom_b": 0.0}
    for train, test in (_folds(n), _folds(n)[::-1]):
        p = solve_rows(d, train)
        sse["free"] += _heading_sse(d, test, p.c_R, p.c_L)
        diff = d.dphi[train, 0] - d.dphi[train, 1]
        c = float(np.sum(diff * d.dyaw[train]) / np.sum(diff**2))  # symmetric: c_R = c_L
        sse["sym"] += _heading_sse(d, test, c, c)
        if b_nominal is not None:
            sse["nom_b"] += _heading_sse(d, test, p.r_R / b_nominal, p.r_L / b_nominal)
    gain_asym = 1 - sse["free"] / sse["sym"] if sse["sym"] > 0 else np.nan
    gain_b = (
        1 - sse["free"] / sse["nom_b"] if b_nominal is not None and sse["nom_b"] > 0 else np.nan
    )
    return float(gain_asym), float(gain_b)


def _relative(name: str, boot: NDArray[np.float64], value: float, unit_note: str) -> Estimate:
    std = float(np.std(boot, ddof=1)) if boot.size > 1 else np.nan
    return Estimate(
        name, value, std, (value - 1.96 * std, value + 1.96 * std), True, "1", unit_note
    )


def discover(
    runs: list[DriveRun], fit: LsqFit, nominal: DiffDriveParams | None
) -> DiffDriveDiscovery:
    """Test the two effects on ``runs`` given their least-squares ``fit`` (with bootstrap)."""
    notes: list[str] = []
    if fit.boot.shape[0] < 20:
        return DiffDriveDiscovery([], ["too few bootstrap replicates to test anything"])
    gain_asym, gain_b = _cv_gains(runs, fit.segment_s, None if nominal is None else nominal.b)
    p = fit.params
    findings = []
    asym = _relative(
        "wheel_radius_asymmetry", fit.ratio_boot - 1, p.r_R / p.r_L - 1, "r_R / r_L - 1"
    )
    lo, hi = asym.ci95
    named = bool((lo > 0 or hi < 0) and gain_asym > 0)
    findings.append(
        Finding(
            "wheel_radius_asymmetry",
            asym,
            gain_asym,
            named,
            f"wheel_radius_asymmetry: r_R/r_L - 1 = {asym.value * 100:+.3f} % "
            f"[95 %: {lo * 100:+.3f}, {hi * 100:+.3f}] %, held-out heading error "
            f"{'reduced' if gain_asym > 0 else 'not reduced'} by {abs(gain_asym) * 100:.1f} %"
            f" -> {'NAMED' if named else 'not named'}",
        )
    )
    if nominal is None:
        notes.append("no nominal track in the log: the effective track cannot be tested")
    else:
        rel = fit.boot[:, 2] / nominal.b - 1
        trk = _relative("effective_track", rel, p.b / nominal.b - 1, "b / b_nominal - 1")
        lo, hi = trk.ci95
        named_b = bool((lo > 0 or hi < 0) and gain_b > 0)
        skid = " (a skid-steer effective track)" if named_b and trk.value > 0.1 else ""
        findings.append(
            Finding(
                "effective_track",
                trk,
                gain_b,
                named_b,
                f"effective_track: b/b_nominal - 1 = {trk.value * 100:+.2f} % "
                f"[95 %: {lo * 100:+.2f}, {hi * 100:+.2f}] % (b = {p.b * 1e3:.1f} mm vs nominal "
                f"{nominal.b * 1e3:.1f} mm), held-out heading error "
                f"{'reduced' if gain_b > 0 else 'not reduced'} by {abs(gain_b) * 100:.1f} %"
                f" -> {'NAMED' if named_b else 'not named'}{skid}",
            )
        )
    return DiffDriveDiscovery(findings, notes)
