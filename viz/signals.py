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
from viz.style import COLORS, TIMELINE

__all__ = ["find_method", "log_segments", "log_signals", "send_series"]


def send_series(
    rec: rr.RecordingStream,
    path: str,
    t_ns: NDArray[np.int64],
    values: NDArray[np.float64],
    *,
    name: str,
    color: str,
) -> None:
    """A named, coloured scalar series; non-finite samples are left out (gaps)."""
    ok = np.isfinite(values)
    if not ok.any():
        return
    rec.log(path, rr.SeriesLines(colors=[COLORS[color]], names=[name], widths=[1.5]), static=True)
    rec.send_columns(
        path,
        indexes=[rr.TimeColumn(TIMELINE, timestamp=t_ns[ok].astype("datetime64[ns]"))],
        columns=rr.Scalars.columns(scalars=values[ok]),
    )


def log_signals(
    rec: rr.RecordingStream,
    frame: pl.DataFrame,
    result: AnalysisResult,
    views: Mapping[str, np.ndarray],
    method_for_psi: str | None = None,
) -> None:
    """Log kappa (1/m), psi (rad) measured and predicted, and residuals under ``signals/``.

    Predictions come with the analysis (``views``, see ``calib.tractor_trailer.views_data``):
    the steady-state psi of the measured curvature at the recommended (L1, L2) and, when
    ``method_for_psi`` names a method, at that method's (L1, L2). Residuals come from
    ``result.discovery.residuals`` when present, else measured minus the recommended
    prediction.
    """
    t = times_ns(frame)
    if has(frame, "kappa_cmd"):
        send_series(
            rec,
            "signals/kappa/command",
            t,
            column(frame, "kappa_cmd"),
            name="κ command",
            color="kappa_cmd",
        )
    if "kappa" in views:
        send_series(
            rec, "signals/kappa/measured", t, views["kappa"], name="κ measured", color="kappa"
        )
    psi = column(frame, "psi") if has(frame, "psi") else None
    if psi is not None:
        send_series(rec, "signals/psi/measured", t, psi, name="ψ measured", color="psi")
    pred = views.get("psi_steady")
    if pred is not None:
        label = result.estimate.method if result.estimate is not None else "truth"
        send_series(
            rec,
            "signals/psi/predicted_estimate",
            t,
            pred,
            name=f"ψ steady state at {label}'s L1, L2",
            color="psi_estimate",
        )
    if method_for_psi is not None and "psi_steady_method" in views:
        send_series(
            rec,
            "signals/psi/predicted_method",
            t,
            views["psi_steady_method"],
            name=f"ψ predicted ({method_for_psi})",
            color="psi_method",
        )
    _log_residuals(rec, result, t, psi, pred)


def _log_residuals(
    rec: rr.RecordingStream,
    result: AnalysisResult,
    t: NDArray[np.int64],
    psi: NDArray[np.float64] | None,
    pred: NDArray[np.float64] | None,
) -> None:
    res = getattr(result.discovery, "residuals", None)
    if res and "t_ns" in res:
        rt = np.asarray(res["t_ns"], dtype=np.int64)
        for key in sorted(k for k in res if k != "t_ns"):
            vals = np.asarray(res[key], dtype=float)
            if vals.shape == rt.shape:
                color = "residual" if key.endswith("_before") else "psi_estimate"
                send_series(rec, f"signals/residuals/{key}", rt, vals, name=key, color=color)
    elif psi is not None and pred is not None:
        send_series(
            rec,
            "signals/residuals/psi",
            t,
            psi - pred,
            name="ψ measured − predicted",
            color="residual",
        )


def log_segments(rec: rr.RecordingStream, frame: pl.DataFrame, result: AnalysisResult) -> None:
    """Segment labels on the timeline: ``segments/type`` state changes (command type) and
    ``segments/log`` text events with times and template parameters, at each segment start."""
    if not result.segments or frame.height == 0:
        return
    t0 = int(times_ns(frame)[0])
    starts = np.array([t0 + round(s.start_s * 1e9) for s in result.segments], dtype=np.int64)
    index = [rr.TimeColumn(TIMELINE, timestamp=starts.astype("datetime64[ns]"))]
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
