"""The default blueprint: the story of one log in a 1600 x 900 window without arranging panels.

Top: the whole path (overview), a close-up that follows link 1 (origin ``world/follow``) with
the ICR construction, and the time series; bottom: the per-method error-bar canvases (a tab
per segment type) beside the summary, methods table and segment log. Time series carry no
overlaid legend: the view names say which colour is which (hover shows each series' name).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import polars as pl
import rerun.blueprint as rrb

from calib.results import AnalysisResult
from viz.raw import raw_views
from viz.style import TIMELINE, y_up_bounds
from viz.tractor_trailer.methods import CANVAS_WIDTH, canvas_height, forest_rows, segment_types
from viz.tractor_trailer.world import FOLLOW, LABELS

__all__ = ["default_blueprint", "follow_half_width", "path_bounds"]


def _whole_log() -> rrb.VisibleTimeRange:
    """Show the whole log whatever the time cursor."""
    return rrb.VisibleTimeRange(
        TIMELINE, start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite()
    )


def _methods_tabs(result: AnalysisResult) -> list[rrb.View]:
    """Per segment type one canvas: method names, L1 and L2 over all rows and near the
    recommended estimate (``viz.tractor_trailer.methods``)."""
    tabs: list[rrb.View] = []
    for seg in segment_types(result):
        rows = forest_rows([m for m in result.methods if m.segment == seg])
        if not rows:
            continue
        tabs.append(
            rrb.Spatial2DView(
                name=f"methods: {seg}",
                origin=f"/methods/{seg}",
                visual_bounds=rrb.VisualBounds2D(
                    x_range=(-1.0, CANVAS_WIDTH + 1.0), y_range=(0.0, canvas_height(rows))
                ),
            )
        )
    return tabs


def _time_axis(t_range_ns: tuple[int, int] | None) -> rrb.TimeAxis | None:
    """Plots span the whole log (not a window following the time cursor)."""
    if t_range_ns is None:
        return None
    start, end = (rrb.TimeRangeBoundary.absolute(nanos=int(t)) for t in t_range_ns)
    return rrb.TimeAxis(view_range=rrb.TimeRange(start=start, end=end))


def path_bounds(views: Mapping[str, np.ndarray]) -> rrb.VisualBounds2D | None:
    """Bounds of the overview: every drawn path point, 5 % margin (y mirrored like the world,
    so the view's y is minus the world's)."""
    pts = [np.asarray(views[k], dtype=float) for k in ("C1", "P", "C2") if k in views]
    if not pts:
        return None
    xy = np.concatenate(pts)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if xy.size == 0:
        return None
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    pad = 0.05 * max(x1 - x0, y1 - y0, 1.0)
    xr, yr = y_up_bounds((x0 - pad, x1 + pad), (y0 - pad, y1 + pad))
    return rrb.VisualBounds2D(x_range=xr, y_range=yr)


def follow_half_width(views: Mapping[str, np.ndarray]) -> float | None:
    """Half width (m) of the close-up: the median turning radius where the ICR is drawn (so
    O shows in a typical turn), kept between 1.5 and 4 times L1 + L2 (the robot stays
    readable); None without lengths."""
    lengths = views.get("lengths")
    if lengths is None:
        return None
    size = float(np.sum(np.abs(lengths)))
    r = np.asarray(views.get("R", []), dtype=float)
    ok = np.asarray(views.get("icr_valid", np.zeros(r.shape, bool)), dtype=bool) & np.isfinite(r)
    typical = 1.2 * float(np.median(np.abs(r[ok]))) if ok.any() else 2.0 * size
    return float(np.clip(typical, 1.5 * size, 4.0 * size))


def _world_views(views: Mapping[str, np.ndarray]) -> list[rrb.View]:
    overview = rrb.Spatial2DView(
        name="World: whole path (C1 red, P orange, C2 blue)",
        origin="/",
        contents=["+ /world/**", f"- /{LABELS}"],
        visual_bounds=path_bounds(views),
    )
    half = follow_half_width(views)
    if half is None:
        return [overview]
    close = rrb.Spatial2DView(
        name="Following link 1: ICR O, Q and triangles",
        origin=f"/{FOLLOW}",
        contents=["+ /world/**"],
        visual_bounds=rrb.VisualBounds2D(x_range=(-half, half), y_range=(-half, half)),
    )
    return [overview, close]


def default_blueprint(
    result: AnalysisResult,
    t_range_ns: tuple[int, int] | None = None,
    y_ranges: dict[str, tuple[float, float]] | None = None,
    views: Mapping[str, np.ndarray] | None = None,
    *,
    raw: Mapping[str, pl.DataFrame] | None = None,
) -> rrb.Blueprint:
    """The overview, the close-up and the time series on top; error bars and texts below.

    Args:
        result: the analysis (method rows and truth set the error-bar canvases).
        t_range_ns: first and last log time (ns): the time axes of the plots. The time cursor
            follows the data to the end of the log, where the ICR of the last turn shows.
        y_ranges: initial y range per plot origin (e.g. "/signals/kappa"), so that a spike
            (kappa = omega / v near standstill) does not flatten a plot.
        views: the drawn arrays (``calib.tractor_trailer.views_data``): bounds of the world
            views.
        raw: the log's topics as read: one plot per topic and unit (``viz.raw.raw_views``).
    """
    y_ranges = y_ranges or {}
    axis = _time_axis(t_range_ns)
    series = [
        rrb.TimeSeriesView(
            name=name,
            origin=origin,
            time_ranges=_whole_log(),
            axis_x=axis,
            axis_y=rrb.ScalarAxis(range=y_ranges[origin]) if origin in y_ranges else None,
            plot_legend=rrb.PlotLegend(visible=False),
        )
        for name, origin in (
            ("κ (1/m): command yellow, measured sky blue", "/signals/kappa"),
            (
                "ψ (rad): measured blue, model green, steady state orange, method purple",
                "/signals/psi",
            ),
            ("ψ residual (rad): baseline grey, with effects green", "/signals/residuals"),
        )
    ]
    right = rrb.Vertical(
        rrb.StateTimelineView(
            name="Segments", origin="/segments/type", time_ranges=_whole_log(), time_view=axis
        ),
        *series,
        row_shares=[2, 3, 3, 3],
    )
    raw_tabs = raw_views(raw or {}, time_ranges=_whole_log(), axis_x=axis)
    docs = rrb.Tabs(
        *raw_tabs,
        rrb.TextDocumentView(name="Summary", origin="/summary"),
        rrb.TextDocumentView(name="Methods table", origin="/methods/table"),
        rrb.TextLogView(name="Segment log", origin="/segments/log"),
    )
    world = _world_views(views or {})
    tabs = _methods_tabs(result)
    bottom = [rrb.Tabs(*tabs), docs] if tabs else [docs]
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(*world, right, column_shares=[1] * len(world) + [2]),
            rrb.Horizontal(*bottom, column_shares=[3, 2][: len(bottom)]),
            row_shares=[9, 11],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state="following"),
    )
