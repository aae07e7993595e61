"""Pick and run the recommended link-length estimator for one log.

The transient output-error fit (``TransientFit``) when speed is available and its fit is sound
(converged, finite covariance, residuals at the sensor-noise level); otherwise the steady-state
errors-in-variables fit (``SteadyStateEIV``), whose verdict then says what the steady state
cannot tell (usually the split between L1 and L2).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from calib.errors import CalibError, InsufficientDataError
from calib.results import CalibrationResult
from calib.tractor_trailer.estimators.eiv import SteadyStateEIV
from calib.tractor_trailer.estimators.transient import TransientFit
from calib.tractor_trailer.results import MethodResult, Segment

__all__ = ["calibrate_link_lengths"]

_EIV_CAVEAT = (
    " (Steady-state fit: it assumes the joint angle is at rest for the measured curvature; "
    "on a log driven with changing curvature the joint angle lags and biases it.)"
)


def _masks(n: int, segments: list[Segment] | None) -> tuple[np.ndarray, slice]:
    """Samples inside the segments (for the steady-state fit) and the contiguous span from the
    first segment's start to the last one's end (for the transient fit)."""
    if not segments:
        return np.ones(n, dtype=bool), slice(0, n)
    mask = np.zeros(n, dtype=bool)
    for s in segments:
        mask[max(s.start_index, 0) : min(s.end_index, n)] = True
    if not mask.any():
        raise InsufficientDataError(
            f"calibrate_link_lengths: the {len(segments)} segments select no samples of {n}"
        )
    idx = np.nonzero(mask)[0]
    return mask, slice(int(idx[0]), int(idx[-1]) + 1)


def calibrate_link_lengths(
    t_s: np.ndarray,
    kappa: np.ndarray,
    psi: np.ndarray,
    v: np.ndarray | None,
    *,
    segments: list[Segment] | None = None,
    rng: np.random.Generator | None = None,
    n_boot: int = 200,
) -> tuple[CalibrationResult, list[MethodResult]]:
    """Recommended (L1, L2) estimate with 95 % intervals and an identifiability verdict.

    Args:
        t_s: sample times (s), strictly increasing.
        kappa: measured curvature of C1 (1/m), e.g. omega / v.
        psi: measured joint angle (rad).
        v: measured speed of C1 (m/s), or None when the log has none (steady-state fit only).
        segments: restrict to these segments (row indices into the arrays); the transient fit
            uses the contiguous span from the first to the last.
        rng, n_boot: accepted for API compatibility and unused: intervals come from
            propagated-noise / Newey-West covariances (no refits), whose coverage
            bench/coverage_study.py checks.

    Returns:
        The recommended ``CalibrationResult`` and the ``MethodResult`` rows "EIV-ML" (family
        "EIV") and ``TransientFit.name`` (family "TRANSIENT") of the fits that ran.

    Raises:
        InsufficientDataError: neither estimator could be fitted (the reasons are joined).
    """
    del rng, n_boot
    t = np.asarray(t_s, dtype=float)
    k = np.asarray(kappa, dtype=float)
    p = np.asarray(psi, dtype=float)
    mask, span = _masks(t.size, segments)
    rows: list[MethodResult] = []
    problems: list[str] = []
    eiv: SteadyStateEIV | None = None
    tr: TransientFit | None = None
    try:
        eiv = SteadyStateEIV().fit(k[mask], p[mask])
        rows.append(eiv.method_result_)
    except CalibError as err:
        problems.append(f"EIV-ML: {err}")
    if v is not None:
        vv = np.asarray(v, dtype=float)
        try:
            tr = TransientFit().fit(t[span], k[span], vv[span], p[span])
            rows.append(tr.method_result_)
        except CalibError as err:
            problems.append(f"{TransientFit.name}: {err}")
    if tr is not None and tr.sound_:
        res = tr.result_
        return replace(res, details={**res.details, "not_used": problems}), rows
    if eiv is None:
        raise InsufficientDataError("calibrate_link_lengths: " + "; ".join(problems))
    res = eiv.result_
    why = []
    if v is None:
        why.append("no speed signal: transient fit not possible")
    elif tr is not None:
        why.append(
            f"transient fit not sound (converged={tr.converged_}, residual rms "
            f"{tr.residual_rms_:.3g} rad vs noise {tr.expected_rms_:.3g} rad)"
        )
    verdict = res.verdict + _EIV_CAVEAT
    details = {**res.details, "why_eiv": why, "not_used": problems}
    return replace(res, verdict=verdict, details=details), rows
