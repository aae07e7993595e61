"""Write a rerun recording (.rrd) of one analysed log with its default blueprint."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import polars as pl
import rerun as rr

from calib.results import PM_MEANING, AnalysisResult
from calib.tractor_trailer.views_data import VIEWS
from viz._frame import column, has, robust_limits
from viz.raw import log_raw_signals
from viz.style import TIMELINE, start_words
from viz.style import application_id as app_id_of
from viz.tractor_trailer.blueprint import default_blueprint
from viz.tractor_trailer.methods import log_methods
from viz.tractor_trailer.signals import find_method, log_segments, log_signals
from viz.tractor_trailer.world import log_world

__all__ = ["summary_markdown", "write_recording"]


def summary_markdown(result: AnalysisResult, start_ns: int | None = None) -> str:
    """Markdown summary: robot, the log's absolute start (``start_ns``, the timeline's zero),
    recommended estimate, truth, what ± means, warnings."""
    parts = [f"# {result.robot}"]
    if start_ns is not None:
        parts.append(f"Time: seconds from the log's start, {start_words(start_ns)}.")
    if result.estimate is not None:
        parts.append("```\n" + result.estimate.report() + "\n```")
    if result.truth:
        parts.append("Truth: " + ", ".join(f"{k} = {v:.4g}" for k, v in result.truth.items()))
    if result.segments:
        kinds = ", ".join(sorted({str(s.command_type) for s in result.segments}))
        parts.append(f"{len(result.segments)} segments ({kinds})")
    parts.append(PM_MEANING)
    parts += [f"- warning: {w}" for w in result.warnings]
    return "\n\n".join(parts)


def _time_range(frame: pl.DataFrame) -> tuple[int, int] | None:
    """(0, last - first) ``t_ns`` of the frame: its span in ns from the log's start (the
    timeline's zero), or None when empty."""
    if frame.height == 0 or "t_ns" not in frame.columns:
        return None
    t = frame["t_ns"].cast(pl.Int64).to_numpy()
    return 0, int(t.max() - t[0])


def _y_ranges(
    frame: pl.DataFrame, views: Mapping[str, np.ndarray]
) -> dict[str, tuple[float, float]]:
    """Robust y ranges of the kappa and psi plots (see ``robust_limits``)."""
    out = {}
    kappa = views.get("kappa")
    groups = {
        "/signals/kappa": [column(frame, "kappa_cmd")] if has(frame, "kappa_cmd") else [],
        "/signals/psi": [column(frame, "psi")] if has(frame, "psi") else [],
    }
    if kappa is not None:
        groups["/signals/kappa"].append(kappa)
    for origin, series in groups.items():
        lim = robust_limits(*series)
        if lim is not None:
            out[origin] = lim
    return out


def write_recording(
    path: str | Path,
    frame: pl.DataFrame,
    result: AnalysisResult,
    views: Mapping[str, np.ndarray] | None = None,
    *,
    method_for_psi: str | None = None,
    application_id: str | None = None,
    raw: Mapping[str, pl.DataFrame] | None = None,
) -> Path:
    """Save the recording of ``frame`` (aligned log) and ``result`` to ``path``.

    Args:
        path: output .rrd file (parent directories are created).
        frame: aligned log with ``t_ns`` (int64, absolute ns) and whatever of kappa_cmd, v,
            omega, x, y, yaw, psi, kappa it has (missing ones are not drawn).
        result: the analysis.
        views: the arrays drawn (``calib.tractor_trailer.views_data.tractor_views_data``);
            None takes them from ``result.artifacts["views"]`` (none there: only measured
            signals are drawn).
        method_for_psi: a method name (e.g. "OLS1(EM1)") whose psi prediction is also shown;
            ``views`` must then hold its ``psi_steady_method``.
        application_id: rerun application id (None: ``viz.style.application_id(result)``, one
            per run, so that each run of a pooled ``.rrd`` keeps its own layout).

    Returns:
        The path written.

    Raises:
        KeyError: ``method_for_psi`` is not a method of ``result``, or ``views`` lacks its
            prediction.
    """
    drawn: Mapping[str, np.ndarray] = result.artifacts.get(VIEWS, {}) if views is None else views
    if method_for_psi is not None:
        find_method(result, method_for_psi)  # fail before writing anything
        if "psi_steady_method" not in drawn:
            raise KeyError(f"no psi prediction of method {method_for_psi!r} in the views data")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(application_id or app_id_of(result))
    blueprint = default_blueprint(
        result, _time_range(frame), _y_ranges(frame, drawn), drawn, raw=raw
    )
    rec.save(out, default_blueprint=blueprint)
    start = int(frame["t_ns"][0]) if frame.height and "t_ns" in frame.columns else None
    try:
        rec.log(
            "summary",
            rr.TextDocument(summary_markdown(result, start), media_type="text/markdown"),
            static=True,
        )
        log_world(rec, frame, drawn)
        log_signals(rec, frame, result, drawn, method_for_psi)
        log_segments(rec, frame, result)
        log_methods(rec, result)
        if raw:
            log_raw_signals(rec, raw, timeline=TIMELINE, origin_ns=start)
    finally:
        rec.flush()
        rec.disconnect()
    return out
