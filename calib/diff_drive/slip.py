"""Speed-dependent wheel slip: is the rolling radius the same at every speed, and what are the
radii and track when it is not.

Longitudinal slip that grows with speed makes each wheel cover (1 - k |u|) of its rolling travel
(u its ground speed, k in s/m). A constant-radius fit then returns the *effective* radius at the
log's speeds, r (1 - k |u|) averaged over them, and its interval, tight as it is, excludes the
radius itself; the residual barely shows it, since a constant scale is exactly a smaller radius.
What does show it is the speed dependence, which this module fits directly: the nominal model
(r_R, r_L, b and the ground-truth marker's offset) with and without the slip coefficient k,
jointly, by nonlinear least squares over short segments (each starting from the true pose), with
Newey-West standard errors over consecutive segments and Student intervals at the segments'
degrees of freedom.

The estimate reported follows what the log shows:

* k significant (|k| / std above ``SLIP_Z``): the slip is named and the radii and track are the
  slip model's (the radius at zero speed), its wheel angles corrected for the slip for the
  adequacy check;
* k not significant but more than ``SPAN_Z`` standard errors from zero: the log cannot tell a
  constant radius from a slightly speed-dependent one, and the two imply different radii; each
  radius and the track span both explanations (:func:`calib.adequacy.span`) instead of claiming
  the constant-radius interval;
* k within ``SPAN_Z`` of zero: the constant-radius estimate as it is.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.stats import t as student_t

from calib.adequacy import span
from calib.diff_drive.data import DriveRun
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.segments import cut_segments, segment_length
from calib.results import Estimate, JsonRecord

__all__ = ["SLIP_Z", "SlipFit", "fit_slip", "slip_corrected", "spanned"]

Array = NDArray[np.float64]

SLIP_Z = 4.0
"""|k| / its standard error above which the log shows speed-dependent slip (Newey-West errors
over a few dozen segments read low by up to a third; 4 keeps clean logs from naming it)."""
SPAN_Z = 1.0
"""|k| / its standard error above which the data lean towards slip enough that the constant-radius
interval must span the slip model's: below it the slip model's zero-speed radius is an
extrapolation the log does not support (a square run's speeds barely vary and would make every
radius interval several per cent wide)."""
MIN_SEGMENTS = 12
NAMES = ("wheel_radius_right", "wheel_radius_left", "track_width")


@dataclass(frozen=True)
class SlipFit(JsonRecord):
    """The nominal model fitted with (``with_slip``) and without (``without``) the slip
    coefficient ``k`` (s/m); ``z`` = k / std; ``significant``: |z| > ``SLIP_Z``; ``params``:
    the slip model's radii and track; ``segment_s``, ``n_segments``: the segments fitted.
    ``params`` and the marker ``offset`` stay out of the JSON (``with_slip`` holds the radii
    and track with their intervals)."""

    json_skip: ClassVar[tuple[str, ...]] = ("params", "offset")

    with_slip: Mapping[str, Estimate]
    without: Mapping[str, Estimate]
    k: Estimate
    z: float
    significant: bool
    segment_s: float
    n_segments: int
    params: DiffDriveParams
    offset: complex = 0j

    @property
    def note(self) -> str:
        k = self.k
        if self.significant:
            return (
                f"the wheels slip more the faster they turn (k = {k.value:.3g} ± "
                f"{k.std:.2g} s/m, {abs(self.z):.1f} standard errors from zero): radii "
                "are the rolling radii at zero speed"
            )
        return (
            f"speed-dependent slip not shown (k = {k.value:.3g} ± {k.std:.2g} s/m): the "
            "interval spans a constant radius and a radius with slip"
        )


def fit_slip(
    runs: Sequence[DriveRun],
    calibrated: DiffDriveParams,
    marker: complex | None,
    *,
    segment_s: float | None = None,
) -> SlipFit | None:
    """Fit the nominal model with and without speed-dependent slip on ``runs`` (see the module
    docstring); ``calibrated`` starts it and sets the residuals' noise scales; None when the
    log holds fewer than ``MIN_SEGMENTS`` moving segments or a fit fails."""
    from calib.diff_drive.effects import ASYMMETRY, WHEEL_SLIP, _Fitter, _Problem, noise_scales

    seg = segment_s if segment_s is not None else segment_length(runs)
    segments = cut_segments(runs, seg)
    if len(segments) < MIN_SEGMENTS:
        return None
    turned = sum(abs(runs[s.run].yaw[s.stop] - runs[s.run].yaw[s.start]) for s in segments)
    prob = _Problem(
        runs,
        segments,
        None,
        0.5 * (calibrated.r_R + calibrated.r_L),
        turned >= math.pi / 2,
        1.0,
        1.0,
    )
    prob.sigma_h, prob.sigma_p = noise_scales(prob, calibrated, marker or 0j)
    fitter = _Fitter(prob, heldout=False)
    without = fitter((ASYMMETRY,))
    with_slip = fitter((ASYMMETRY, WHEEL_SLIP))
    if without is None or with_slip is None:
        return None
    k = with_slip.effect_parameters[WHEEL_SLIP.key]["k"]
    dof = max(2, len(segments) - with_slip.k)
    q = float(student_t.ppf(0.975, dof))
    z = k.value / k.std if k.std > 0 else 0.0
    params = with_slip.payload["params"]
    v = with_slip.payload["values"]
    return SlipFit(
        _t_intervals(with_slip.parameters, q),
        _t_intervals(without.parameters, q),
        _t_intervals({"k": k}, q)["k"],
        float(z),
        bool(abs(z) > SLIP_Z),
        seg,
        len(segments),
        params,
        complex(v.get("lx", 0.0), v.get("ly", 0.0)),
    )


def _t_intervals(est: Mapping[str, Estimate], q: float) -> dict[str, Estimate]:
    out = {}
    for n, e in est.items():
        half = q * e.std
        out[n] = Estimate(
            e.name,
            e.value,
            e.std,
            (e.value - half, e.value + half),
            e.identifiable and math.isfinite(e.std),
            e.unit,
            f"joint least squares over segments, Newey-West errors, t {q:.2f}",
        )
    return out


def slip_corrected(runs: Sequence[DriveRun], params: DiffDriveParams, k: float) -> list[DriveRun]:
    """``runs`` with each wheel's angle replaced by its ground travel over its zero-speed
    radius: increments scaled by (1 - k r |wheel ground speed|), so that the constant-radius
    model with ``params`` describes a log that slips with coefficient ``k``."""
    out = []
    for run in runs:
        if run.n < 2 or k == 0:
            out.append(run)
            continue
        dt = np.maximum(np.diff(run.t), 1e-9)
        dr, dl = np.diff(run.wheel_right), np.diff(run.wheel_left)
        dr = dr * (1 - k * params.r_R * np.abs(dr) / dt)
        dl = dl * (1 - k * params.r_L * np.abs(dl) / dt)
        out.append(
            DriveRun(
                run.t,
                run.wheel_right[0] + np.concatenate([[0.0], np.cumsum(dr)]),
                run.wheel_left[0] + np.concatenate([[0.0], np.cumsum(dl)]),
                run.x,
                run.y,
                run.yaw,
                name=run.name,
            )
        )
    return out


def spanned(
    estimates: Mapping[str, Estimate], slip: SlipFit, *, rel_tol: float = 0.05
) -> dict[str, Estimate]:
    """The radii and track of ``estimates`` (the constant-radius fit) spanning the slip
    model's (:func:`calib.adequacy.span`) where the slip model's interval reaches beyond
    theirs, once the fitted slip leans away from zero (|z| > ``SPAN_Z``); other estimates
    unchanged."""
    out = dict(estimates)
    if abs(slip.z) <= SPAN_Z:
        return out
    for n in NAMES:
        e, s = estimates.get(n), slip.with_slip.get(n)
        if e is None or s is None:
            continue
        if s.ci95[0] >= e.ci95[0] and s.ci95[1] <= e.ci95[1]:
            continue
        sp = span([e, s], ["constant radius", "speed-dependent slip"], rel_tol=rel_tol)
        out[n] = Estimate(
            e.name,
            e.value,
            sp.std,
            sp.ci95,
            sp.identifiable,
            e.unit,
            (e.note + "; " if e.note else "") + slip.note,
        )
    return out
