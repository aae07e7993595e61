"""The default blueprint: the story of one log without arranging panels."""

from __future__ import annotations

import rerun.blueprint as rrb

from calib.results import AnalysisResult
from viz.methods import PARAMS, forest_layout, segment_types
from viz.style import TIMELINE

__all__ = ["default_blueprint"]


def _whole_log() -> rrb.VisibleTimeRange:
    """Show the whole log whatever the time cursor."""
    return rrb.VisibleTimeRange(
        TIMELINE, start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite()
    )


def _methods_tabs(result: AnalysisResult) -> list[rrb.Container]:
    """Per segment type a tab with the L1 and L2 forest plots side by side, zoomed on the
    bulk of the estimates (ill-conditioned outliers lie outside; zoom out to see them)."""
    tabs: list[rrb.Container] = []
    for seg in segment_types(result):
        rows = [m for m in result.methods if m.segment == seg]
        views = []
        for p in PARAMS:
            lay = forest_layout(rows, p, result.truth.get(p))
            views.append(
                rrb.Spatial2DView(
                    name=f"{p} per method ({seg}), m",
                    origin=f"/methods/{seg}/{p}",
                    visual_bounds=rrb.VisualBounds2D(x_range=lay.x_range, y_range=lay.y_range),
                )
            )
        tabs.append(rrb.Horizontal(*views, name=f"methods: {seg}"))
    return tabs


def _time_axis(t_range_ns: tuple[int, int] | None) -> rrb.TimeAxis | None:
    """Plots span the whole log (not a window following the time cursor)."""
    if t_range_ns is None:
        return None
    start, end = (rrb.TimeRangeBoundary.absolute(nanos=int(t)) for t in t_range_ns)
    return rrb.TimeAxis(view_range=rrb.TimeRange(start=start, end=end))


def default_blueprint(
    result: AnalysisResult,
    t_range_ns: tuple[int, int] | None = None,
    y_ranges: dict[str, tuple[float, float]] | None = None,
) -> rrb.Blueprint:
    """World + ICR on the left; segment types, kappa, psi and residuals over time on the right;
    per-method error bars (a tab per segment type) and summary / table / segment log below.

    Args:
        result: the analysis (method rows and truth set the error-bar panels).
        t_range_ns: first and last log time (ns): the time axes of the plots. The time cursor
            follows the data to the end of the log, where the ICR of the last turn shows.
        y_ranges: initial y range per plot origin (e.g. "/signals/kappa"), so that a spike
            (kappa = omega / v near standstill) does not flatten a plot.
    """
    y_ranges = y_ranges or {}
    axis = _time_axis(t_range_ns)
    world = rrb.Spatial2DView(name="World: paths, robot, ICR", origin="/", contents=["+ /world/**"])
    series = [
        rrb.TimeSeriesView(
            name=name,
            origin=origin,
            time_ranges=_whole_log(),
            axis_x=axis,
            axis_y=rrb.ScalarAxis(range=y_ranges[origin]) if origin in y_ranges else None,
        )
        for name, origin in (
            ("κ command vs measured (1/m)", "/signals/kappa"),
            ("ψ measured vs predicted (rad)", "/signals/psi"),
            ("Residuals", "/signals/residuals"),
        )
    ]
    right = rrb.Vertical(
        rrb.StateTimelineView(
            name="Segments", origin="/segments/type", time_ranges=_whole_log(), time_view=axis
        ),
        *series,
        row_shares=[2, 3, 3, 3],
    )
    docs = rrb.Tabs(
        rrb.TextDocumentView(name="Summary", origin="/summary"),
        rrb.TextDocumentView(name="Methods table", origin="/methods/table"),
        rrb.TextLogView(name="Segment log", origin="/segments/log"),
    )
    tabs = _methods_tabs(result)
    bottom = [rrb.Tabs(*tabs), docs] if tabs else [docs]
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(world, right, column_shares=[1, 1]),
            rrb.Horizontal(*bottom, column_shares=[3, 2][: len(bottom)]),
            row_shares=[1, 1],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state="following"),
    )
