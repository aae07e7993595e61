"""The arrays the tractor-trailer's views draw, computed here so that ``viz`` computes no model.

``tractor_views_data`` takes the aligned log's columns and the analysis and returns, per
sample of the log (n samples):

- ``kappa``: the measured curvature of C1 (1/m): ``kappa`` when logged, else omega / v (NaN
  below 1 mm/s), the curvature every prediction below uses;
- ``lengths``: (2,) the (L1, L2) (m) drawn: the recommended estimate's, else the truth's
  (absent when neither has them; then only C1 is drawn and nothing is predicted);
- ``psi_steady``: the steady-state joint angle (rad) at ``lengths`` for ``kappa``
  (the patent's model; NaN where no steady state exists);
- ``psi_steady_method``: the same at the lengths of the method named by ``method_for_psi``;
- ``C1``, ``P``, ``C2`` (n, 2): link points (m, world frame); ``O``, ``Q`` (n, 2), ``R`` (n,)
  and ``icr_valid`` (n,): the instantaneous-centre construction
  (``calib.tractor_trailer.models.icr``).

and, when the recommended estimate is a transient fit along the path (``transient`` given),
per joint-angle sample that fit used (m samples, on the joint angle's own stamps):

- ``psi_model_t_ns`` (m,) int64: the sample's time stamp (ns, the log's clock);
- ``psi_model`` (m,): the joint angle (rad) that fit's model simulates along the measured path
  (``PathTransientFit.psi_fit_``: the transient kinematics, with its sensor offset if fitted);
- ``psi_model_params`` (3,): the (L1, L2, psi offset) (m, m, rad) the simulation used (the
  optimiser's values, before the first-order noise-bias correction of the reported estimate);
- ``psi_model_residual`` (m,): measured minus ``psi_model`` (rad).

The analysis keeps them in ``AnalysisResult.artifacts[VIEWS]`` (not part of the JSON).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.results import AnalysisResult
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.models.icr import KAPPA_MIN, icr_construction
from calib.tractor_trailer.results import MethodResult

__all__ = [
    "VIEWS",
    "TransientPrediction",
    "find_method",
    "measured_curvature",
    "tractor_views_data",
    "transient_prediction",
    "view_lengths",
]

#: Key of ``AnalysisResult.artifacts`` holding ``tractor_views_data``'s arrays.
VIEWS = "views"

FloatArray = NDArray[np.float64]


class TransientPrediction(Protocol):
    """What a fitted ``calib.tractor_trailer.estimators.path_transient.PathTransientFit``
    offers the views."""

    t_s_: np.ndarray
    psi_fit_: np.ndarray
    psi_offset_: float
    L1_: float
    L2_: float
    bias_correction_: np.ndarray
    residual_: np.ndarray


def transient_prediction(
    fit: TransientPrediction, t0_ns: int, psi_shift_s: float = 0.0
) -> dict[str, np.ndarray]:
    """``psi_model_t_ns``, ``psi_model`` and ``psi_model_params`` of a transient path fit
    (see the module docstring). ``t0_ns``: the fit's time origin; ``psi_shift_s``: the clock
    offset (s) the fit took off the joint-angle stamps (added back: drawn at the stamps)."""
    t_s = np.asarray(fit.t_s_, dtype=float) + psi_shift_s
    # the simulation ran at the optimiser's lengths: the estimate minus its bias correction
    l1, l2 = fit.L1_ - fit.bias_correction_[0], fit.L2_ - fit.bias_correction_[1]
    return {
        "psi_model_t_ns": np.int64(t0_ns) + np.round(t_s * 1e9).astype(np.int64),
        "psi_model": np.asarray(fit.psi_fit_, dtype=float),
        "psi_model_residual": np.asarray(fit.residual_, dtype=float),
        "psi_model_params": np.array([l1, l2, fit.psi_offset_], dtype=float),
    }


def _col(arrays: Mapping[str, ArrayLike], name: str) -> FloatArray | None:
    return np.asarray(arrays[name], dtype=float) if name in arrays else None


def measured_curvature(arrays: Mapping[str, ArrayLike]) -> FloatArray | None:
    """Curvature of C1 (1/m): ``kappa`` if present, else ``omega / v`` (NaN where |v| <= 1e-3
    m/s); None if neither."""
    kappa = _col(arrays, "kappa")
    if kappa is not None:
        return kappa
    omega, v = _col(arrays, "omega"), _col(arrays, "v")
    if omega is None or v is None:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.abs(v) > 1e-3, omega / v, np.nan)


def view_lengths(result: AnalysisResult) -> tuple[float, float] | None:
    """(L1, L2) in m from the recommended estimate, else the truth; None when neither has them."""
    est = result.estimate
    if est is not None and "L1" in est.parameters and "L2" in est.parameters:
        l1, l2 = est.parameters["L1"].value, est.parameters["L2"].value
        if np.isfinite(l1) and np.isfinite(l2):
            return float(l1), float(l2)
    if "L1" in result.truth and "L2" in result.truth:
        return float(result.truth["L1"]), float(result.truth["L2"])
    return None


def find_method(result: AnalysisResult, name: str) -> MethodResult:
    """The method ``name`` (e.g. "OLS1(EM1)"), preferring its row over all segments.

    Raises:
        KeyError: no method of that name; the message lists the available ones.
    """
    rows = [m for m in result.methods if m.name == name]
    if not rows:
        known = sorted({m.name for m in result.methods})
        raise KeyError(f"method {name!r} not in the analysis; available: {', '.join(known)}")
    return next((m for m in rows if m.segment == "all"), rows[0])


def tractor_views_data(
    frame_arrays: Mapping[str, ArrayLike],
    result: AnalysisResult,
    *,
    method_for_psi: str | None = None,
    kappa_min: float = KAPPA_MIN,
    transient: Mapping[str, np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """The arrays the tractor-trailer's views draw (see the module docstring for the keys).

    Args:
        frame_arrays: the aligned log's columns by name (whatever of x, y, yaw (m, m, rad),
            psi (rad), kappa (1/m), omega (rad/s), v (m/s) it has), all of one length.
        result: the analysis (its estimate, truth and methods give the lengths).
        method_for_psi: also predict psi with this method's (L1, L2).
        kappa_min: |kappa| (1/m) below which the ICR is not constructed.
        transient: ``transient_prediction`` of the fit behind the recommended estimate (when
            that estimate is a transient fit along the path); its arrays are passed on.

    Raises:
        KeyError: ``method_for_psi`` is not a method of ``result``.
    """
    out: dict[str, np.ndarray] = dict(transient or {})
    kappa = measured_curvature(frame_arrays)
    lengths = view_lengths(result)
    method = find_method(result, method_for_psi) if method_for_psi is not None else None
    if kappa is None:
        return out
    out["kappa"] = kappa
    if lengths is not None:
        out["lengths"] = np.asarray(lengths, dtype=float)
        out["psi_steady"] = steady_state_psi(kappa, *lengths)
    if method is not None:
        out["psi_steady_method"] = steady_state_psi(kappa, method.L1, method.L2)
    pose = [_col(frame_arrays, n) for n in ("x", "y", "yaw", "psi")]
    if lengths is not None and all(c is not None for c in pose):
        x, y, yaw, psi = (np.asarray(c, dtype=float) for c in pose)
        c = icr_construction(x, y, yaw, psi, kappa, *lengths, kappa_min=kappa_min)
        out.update(C1=c.C1, P=c.P, C2=c.C2, O=c.O, Q=c.Q, R=c.R, icr_valid=c.valid)
    return out
