"""Differential-drive discovery: does the log contradict the nominal model (equal wheel radii,
the nominal track, rolling without systematic slip)? Each effect is named only when (1) its
interval at the family-wise level excludes the null and (2) allowing it improves the fit of
held-out segments (two-fold cross-validation over alternating blocks of segments, so
neighbours that share slip do not leak between folds):

* ``wheel_radius_asymmetry``: r_R / r_L - 1 (null 0); held out: the yaw change per segment;
* ``effective_track``: b / b_nominal - 1 (null 0, needs a nominal track); held out: the yaw
  change per segment with the fitted radii and the nominal vs fitted track. An effective track
  much wider than the geometric one is the signature of a skid-steer robot.
* ``wheel_slip``: speed-proportional longitudinal slip, each wheel's ground travel its rolling
  travel times (1 - k |wheel ground speed|); k (1 / (m/s), null 0) from the yaw change per
  segment, where it enters through the speed-weighted wheel turns. A *constant* slip fraction
  is exactly a smaller wheel radius (same kinematics), so no log can tell it apart: it is
  absorbed by the calibrated radii (the effective rolling radius), not tested.

Why the level is corrected: with m effects each tested at 95 %, a clean log raises some alarm
with probability up to m x 5 %; each interval is taken at 1 - 0.05 / m (Bonferroni), so the
chance of any false alarm stays below 5 % whatever the dependence between the tests. The
intervals are value ± t * bootstrap std with t on the bootstrap's degrees of freedom (see
:mod:`calib.diff_drive.odometry_lsq`). The held-out check is a further filter, never a
substitute: it only removes findings.

Each of the three is a closed-form test on the least-squares heading design with its own
bootstrap, not a hook: this module is the linear check beside the LSQ calibration. Effects are
added to the differential drive in :mod:`calib.diff_drive.effects` (a catalogue entry with its
hook, tried by the shared selection engine); the names here are that catalogue's ids.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.data import DriveRun
from calib.diff_drive.effects import ASYMMETRY, EFFECTIVE_TRACK, WHEEL_SLIP
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import LsqFit, segment_design, solve_rows
from calib.diff_drive.segments import SegmentIndex
from calib.results import Estimate, json_safe
from calib.stats import alternate_blocks

__all__ = ["DiffDriveDiscovery", "Finding", "discover"]

CV_BLOCK = 5
"""Segments per block of the two-fold cross-validation."""

SLIP_COND_MAX = 1e3
"""Condition number of the (column-scaled) heading design with the slip column above which the
wheel speeds are too uniform for slip to be told from the radii."""

FAMILY_ALPHA = 0.05
"""Family-wise false-alarm rate of discovery on a clean log (split over the effects tested)."""


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
    return alternate_blocks(n, CV_BLOCK)


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


def _relative(
    name: str, boot: NDArray[np.float64], value: float, unit_note: str, fit: LsqFit, unit: str = "1"
) -> Estimate:
    std = float(np.std(boot, ddof=1)) if boot.size > 1 else np.nan
    q = fit.quantile(0.95)
    return Estimate(name, value, std, (value - q * std, value + q * std), True, unit, unit_note)


def _excludes_null(e: Estimate, q: float) -> tuple[bool, float, float]:
    """Whether value ± q std excludes 0, and that interval."""
    lo, hi = e.value - q * e.std, e.value + q * e.std
    return bool(np.isfinite(e.std) and (lo > 0 or hi < 0)), lo, hi


def _speed_weighted_turns(
    runs: list[DriveRun], segments: list[SegmentIndex], r_R: float, r_L: float
) -> NDArray[np.float64]:
    """Per segment, sum over its intervals of |wheel ground speed| (m/s) x wheel turn (rad),
    right and left: what speed-proportional slip removes from each wheel's turn, per unit k."""
    out = np.zeros((len(segments), 2))
    cums: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for i, s in enumerate(segments):
        if s.run not in cums:
            run = runs[s.run]
            dt = np.maximum(np.diff(run.t), 1e-9)
            dr, dl = np.diff(run.wheel_right), np.diff(run.wheel_left)
            qr = np.concatenate([[0.0], np.cumsum(r_R * np.abs(dr) / dt * dr)])
            ql = np.concatenate([[0.0], np.cumsum(r_L * np.abs(dl) / dt * dl)])
            cums[s.run] = (qr, ql)
        qr, ql = cums[s.run]
        out[i] = [qr[s.stop] - qr[s.start], ql[s.stop] - ql[s.start]]
    return out


def _slip_solve(
    dphi: NDArray[np.float64], Q: NDArray[np.float64], dyaw: NDArray[np.float64]
) -> tuple[float, float, float, float, float]:
    """Heading model with and without slip on the given rows: (c_R, c_L) without; then
    yaw = c_R (A_R - k Q_R) - c_L (A_L - k Q_L), linearised about the slip-free c's (one
    Gauss-Newton step, exact to first order in k). Returns c_R0, c_L0, c_R, c_L, k."""
    A = dphi * np.array([1.0, -1.0])
    (c_R0, c_L0), *_ = np.linalg.lstsq(A, dyaw, rcond=None)
    slip_col = -(c_R0 * Q[:, 0] - c_L0 * Q[:, 1])
    (c_R, c_L, k), *_ = np.linalg.lstsq(np.column_stack([A, slip_col]), dyaw, rcond=None)
    return float(c_R0), float(c_L0), float(c_R), float(c_L), float(k)


def _slip_finding(runs: list[DriveRun], fit: LsqFit, q_test: float, level: float) -> Finding | None:
    """The wheel_slip test (None when the log's speeds do not vary enough to separate k from
    the radii: a robot always at one speed shows slip only as a radius)."""
    d = segment_design(runs, fit.segment_s)
    n = len(d.segments)
    if n < 4 * CV_BLOCK:
        return None
    Q = _speed_weighted_turns(runs, d.segments, fit.params.r_R, fit.params.r_L)
    c_R, c_L = fit.params.c_R, fit.params.c_L
    X = np.column_stack([d.dphi[:, 0], -d.dphi[:, 1], -(c_R * Q[:, 0] - c_L * Q[:, 1])])
    norms = np.linalg.norm(X, axis=0)
    if np.any(norms == 0) or np.linalg.cond(X / norms) > SLIP_COND_MAX:
        return None
    k = _slip_solve(d.dphi, Q, d.dyaw)[4]
    rng = np.random.default_rng(12345)
    boot = []
    blk = fit.block
    for _ in range(max(fit.boot.shape[0], 20)):
        starts = rng.integers(0, n - blk + 1, size=int(np.ceil(n / blk)))
        rows = (starts[:, None] + np.arange(blk)[None, :]).ravel()[:n]
        boot.append(_slip_solve(d.dphi[rows], Q[rows], d.dyaw[rows])[4])
    est = _relative(
        WHEEL_SLIP.id, np.array(boot), k, "k: fraction of wheel travel lost per m/s", fit, "s/m"
    )
    sse0 = sse1 = 0.0
    for train, test in (_folds(n), _folds(n)[::-1]):
        c_R0, c_L0, c_R, c_L, kk = _slip_solve(d.dphi[train], Q[train], d.dyaw[train])
        A = d.dphi[test] * np.array([1.0, -1.0])
        sse0 += float(np.sum((d.dyaw[test] - A @ np.array([c_R0, c_L0])) ** 2))
        pred = A @ np.array([c_R, c_L]) - kk * (c_R0 * Q[test, 0] - c_L0 * Q[test, 1])
        sse1 += float(np.sum((d.dyaw[test] - pred) ** 2))
    gain = 1 - sse1 / sse0 if sse0 > 0 else np.nan
    excl, lo, hi = _excludes_null(est, q_test)
    named = bool(excl and gain > 0)
    return Finding(
        WHEEL_SLIP.id,
        est,
        float(gain),
        named,
        f"{WHEEL_SLIP.id}: k = {k * 100:+.2f} % of wheel travel per m/s [{level:.1%}: "
        f"{lo * 100:+.2f}, {hi * 100:+.2f}] %, held-out heading error "
        f"{'reduced' if gain > 0 else 'not reduced'} by {abs(gain) * 100:.1f} %"
        f" -> {'NAMED' if named else 'not named'}",
    )


def discover(
    runs: list[DriveRun], fit: LsqFit, nominal: DiffDriveParams | None
) -> DiffDriveDiscovery:
    """Test the effects on ``runs`` given their least-squares ``fit`` (with bootstrap)."""
    notes: list[str] = []
    if fit.boot.shape[0] < 20:
        return DiffDriveDiscovery([], ["too few bootstrap replicates to test anything"])
    gain_asym, gain_b = _cv_gains(runs, fit.segment_s, None if nominal is None else nominal.b)
    m = 3 if nominal is not None else 2
    level = 1 - FAMILY_ALPHA / m
    q_test = fit.quantile(level)
    notes.append(
        f"{m} effects tested, each at the {level:.1%} level (Bonferroni: family-wise false-alarm "
        f"rate <= {FAMILY_ALPHA:.0%}); t quantile {q_test:.2f} on {fit.dof} degrees of freedom"
    )
    p = fit.params
    findings = []
    asym = _relative(ASYMMETRY.id, fit.ratio_boot - 1, p.r_R / p.r_L - 1, "r_R / r_L - 1", fit)
    excl, lo, hi = _excludes_null(asym, q_test)
    named = bool(excl and gain_asym > 0)
    findings.append(
        Finding(
            ASYMMETRY.id,
            asym,
            gain_asym,
            named,
            f"{ASYMMETRY.id}: r_R/r_L - 1 = {asym.value * 100:+.3f} % "
            f"[{level:.1%}: {lo * 100:+.3f}, {hi * 100:+.3f}] %, held-out heading error "
            f"{'reduced' if gain_asym > 0 else 'not reduced'} by {abs(gain_asym) * 100:.1f} %"
            f" -> {'NAMED' if named else 'not named'}",
        )
    )
    if nominal is None:
        notes.append("no nominal track in the log: the effective track cannot be tested")
    else:
        rel = fit.boot[:, 2] / nominal.b - 1
        trk = _relative(EFFECTIVE_TRACK.id, rel, p.b / nominal.b - 1, "b / b_nominal - 1", fit)
        excl, lo, hi = _excludes_null(trk, q_test)
        named_b = bool(excl and gain_b > 0)
        skid = " (a skid-steer effective track)" if named_b and trk.value > 0.1 else ""
        findings.append(
            Finding(
                EFFECTIVE_TRACK.id,
                trk,
                gain_b,
                named_b,
                f"{EFFECTIVE_TRACK.id}: b/b_nominal - 1 = {trk.value * 100:+.2f} % "
                f"[{level:.1%}: {lo * 100:+.2f}, {hi * 100:+.2f}] % (b = {p.b * 1e3:.1f} mm vs "
                f"nominal {nominal.b * 1e3:.1f} mm), held-out heading error "
                f"{'reduced' if gain_b > 0 else 'not reduced'} by {abs(gain_b) * 100:.1f} %"
                f" -> {'NAMED' if named_b else 'not named'}{skid}",
            )
        )
    slip = _slip_finding(runs, fit, q_test, level)
    if slip is None:
        notes.append(
            f"{WHEEL_SLIP.id} not tested: too few segments, or wheel speeds too uniform to tell "
            "speed-proportional slip from the radii"
        )
    else:
        findings.append(slip)
    return DiffDriveDiscovery(findings, notes)
