"""Time-series part of the recording: curvature, joint angle, predictions, residuals, segments.

All series go through ``rr.send_columns`` on the log's own timeline.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import polars as pl
import rerun as rr
from numpy.typing import NDArray

from calib.results import AnalysisResult
from calib.tractor_trailer.views_data import find_method
from viz._frame import column, has, times_ns
from viz.style import COLORS, time_index

__all__ = ["find_method", "log_segments", "log_signals", "psi_curve_names", "send_series"]


def send_series(
    rec: rr.RecordingStream,
    path: str,
    t_ns: NDArray[np.int64],
    values: NDArray[np.float64],
    *,
    name: str,
    color: str,
    origin_ns: int,
    width: float = 1.5,
) -> None:
    """A named, coloured scalar series on the timeline in seconds from ``origin_ns`` (the log's
    start); non-finite samples are left out (gaps)."""
    ok = np.isfinite(values)
    if not ok.any():
        return
    rec.log(path, rr.SeriesLines(colors=[COLORS[color]], names=[name], widths=[width]), static=True)
    rec.send_columns(
        path,
        indexes=time_index(t_ns[ok], origin_ns),
        columns=rr.Scalars.columns(scalars=values[ok]),
    )


def _lengths_text(l1: float, l2: float) -> str:
    return f"L1 = {l1:.3f} m, L2 = {l2:.3f} m"


def _reported_lengths(est: object) -> str | None:
    """The recommended L1, L2 as the report writes them (``L1 = 1.253 m, L2 = 2.477 m``), None
    when the estimate carries no such parameters."""
    params = getattr(est, "parameters", {}) or {}
    if "L1" not in params or "L2" not in params:
        return None
    return _lengths_text(float(params["L1"].value), float(params["L2"].value))


def psi_curve_names(
    result: AnalysisResult, views: Mapping[str, np.ndarray], method_for_psi: str | None = None
) -> dict[str, str]:
    """Name of each predicted joint-angle curve in ``views`` (keys ``psi_model``,
    ``psi_steady``, ``psi_steady_method``): which model and which parameters drew it."""
    names = {}
    est = result.estimate
    if "psi_model" in views and est is not None:
        l1, l2, off = (float(x) for x in views["psi_model_params"])
        tail = f", ψ offset {off:+.4f} rad" if off else ""
        reported = _reported_lengths(est)
        names["psi_model"] = (
            f"ψ of {est.method} (recommended): transient kinematics simulated along the "
            f"measured path at the optimiser's {_lengths_text(l1, l2)}{tail}"
            + (f" (estimate after its bias correction: {reported})" if reported else "")
        )
    if "psi_steady" in views and "lengths" in views:
        l1, l2 = (float(x) for x in views["lengths"])
        whose = "the truth" if est is None else f"{est.method}'s estimate"
        names["psi_steady"] = (
            f"ψ steady-state relation (patent) at {whose}, {_lengths_text(l1, l2)}"
        )
    if method_for_psi is not None and "psi_steady_method" in views:
        m = find_method(result, method_for_psi)
        names["psi_steady_method"] = (
            f"ψ steady-state relation at {method_for_psi}, {_lengths_text(m.L1, m.L2)}"
        )
    return names


def log_signals(
    rec: rr.RecordingStream,
    frame: pl.DataFrame,
    result: AnalysisResult,
    views: Mapping[str, np.ndarray],
    method_for_psi: str | None = None,
) -> None:
    """Log kappa (1/m), psi (rad) measured and predicted, and residuals under ``signals/``.

    Predictions come with the analysis (``views``, see ``calib.tractor_trailer.views_data``):
    the recommended model's own prediction when it is a transient fit along the path
    (``psi_model``, on the joint angle's stamps), the steady-state relation of the measured
    curvature at the recommended (L1, L2) and, when ``method_for_psi`` names a method, at that
    method's (L1, L2); each series is named by ``psi_curve_names``. Residuals come from
    ``result.discovery.residuals`` when present (joint angle only: one unit per plot), else
    measured minus the recommended model's prediction.
    """
    t = times_ns(frame)
    if len(t) == 0:
        return
    t0 = int(t[0])
    if has(frame, "kappa_cmd"):
        send_series(
            rec,
            "signals/kappa/command",
            t,
            column(frame, "kappa_cmd"),
            name="κ command",
            color="kappa_cmd",
            origin_ns=t0,
            width=4.0,  # wider than the measured line drawn over it: both stay visible
        )
    if "kappa" in views:
        send_series(
            rec,
            "signals/kappa/measured",
            t,
            views["kappa"],
            name="κ measured",
            color="kappa",
            origin_ns=t0,
            width=1.0,
        )
    psi = column(frame, "psi") if has(frame, "psi") else None
    if psi is not None:
        send_series(
            rec,
            "signals/psi/measured",
            t,
            psi,
            name="ψ measured",
            color="psi",
            width=3.0,
            origin_ns=t0,
        )
    names = psi_curve_names(result, views, method_for_psi)
    if "psi_model" in names:
        send_series(
            rec,
            "signals/psi/predicted_model",
            np.asarray(views["psi_model_t_ns"], dtype=np.int64),
            views["psi_model"],
            name=names["psi_model"],
            color="psi_estimate",
            origin_ns=t0,
        )
    pred = views.get("psi_steady")
    if pred is not None and "psi_steady" in names:
        send_series(
            rec,
            "signals/psi/predicted_estimate",
            t,
            pred,
            name=names["psi_steady"],
            color="psi_steady",
            origin_ns=t0,
        )
    if "psi_steady_method" in names:
        send_series(
            rec,
            "signals/psi/predicted_method",
            t,
            views["psi_steady_method"],
            name=names["psi_steady_method"],
            color="psi_method",
            origin_ns=t0,
        )
    _log_residuals(rec, result, t, psi, views)


def _log_residuals(
    rec: rr.RecordingStream,
    result: AnalysisResult,
    t: NDArray[np.int64],
    psi: NDArray[np.float64] | None,
    views: Mapping[str, np.ndarray],
) -> None:
    t0 = int(t[0])
    res = getattr(result.discovery, "residuals", None)
    if res and "t_ns" in res:
        rt = np.asarray(res["t_ns"], dtype=np.int64)
        for key in sorted(k for k in res if k.startswith("psi")):
            vals = np.asarray(res[key], dtype=float)
            if vals.shape == rt.shape:
                before = key.endswith("_before")
                name = (
                    "ψ residual of the baseline"
                    if before
                    else ("ψ residual with the effects discovery accepted")
                )
                send_series(
                    rec,
                    f"signals/residuals/{key}",
                    rt,
                    vals,
                    name=name,
                    color="residual" if before else "psi_estimate",
                    origin_ns=t0,
                )
        return
    if "psi_model_residual" in views:
        send_series(
            rec,
            "signals/residuals/psi",
            np.asarray(views["psi_model_t_ns"], np.int64),
            views["psi_model_residual"],
            name="ψ measured − recommended model",
            color="residual",
            origin_ns=t0,
        )
    elif psi is not None and "psi_steady" in views:
        send_series(
            rec,
            "signals/residuals/psi",
            t,
            psi - views["psi_steady"],
            name="ψ measured − steady-state relation",
            color="residual",
            origin_ns=t0,
        )


def log_segments(rec: rr.RecordingStream, frame: pl.DataFrame, result: AnalysisResult) -> None:
    """Segment labels on the timeline: ``segments/type`` state changes (command type) and
    ``segments/log`` text events with times and template parameters, at each segment start."""
    if not result.segments or frame.height == 0:
        return
    starts = np.array([round(s.start_s * 1e9) for s in result.segments], dtype=np.int64)
    index = time_index(starts, 0)  # segment starts are seconds from the log's start already
    rec.send_columns(
        "segments/type",
        indexes=index,
        columns=rr.StateChange.columns(state=[str(s.command_type) for s in result.segments]),
    )
    text = [
        f"{s.command_type} segment {s.start_s:.1f}–{s.end_s:.1f} s"
        + "".join(f", {k}={v:.3g}" for k, v in s.parameters.items())
        for s in result.segments
    ]
    rec.send_columns(
        "segments/log",
        indexes=index,
        columns=rr.TextLog.columns(text=text, level=["INFO"] * len(text)),
    )
