"""Views of a differential-drive analysis: ground truth vs dead-reckoned paths (nominal and
calibrated parameters) per run, and each method's parameters with 95 % intervals, in a rerun
recording laid out for a 1600 x 900 window and in a static PNG.

Draws only what the analysis carries (``result.artifacts["trajectories"]``: run -> label ->
x, y arrays; ``result.methods``: one ``CalibrationResult`` per method).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from calib.results import PM_MEANING, AnalysisResult, CalibrationResult, Estimate
from viz.loaded import LoadedLike
from viz.raw import log_raw_signals, raw_views
from viz.style import (
    COLORS,
    TIMELINE,
    application_id,
    hex_color,
    start_words,
    y_up,
    y_up_bounds,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["grid_labels", "grid_lines", "log_views", "report_figure", "write_png"]

_COLOURS = {  # the viewer's light or dark theme (viz.style.THEME_BACKGROUNDS)
    "truth": COLORS["truth"],
    "nominal": COLORS["dd_nominal"],
    "calibrated": COLORS["dd_calibrated"],
}
_PNG_COLOURS = {  # the report image's white background
    "truth": "#000000",
    "nominal": hex_color("dd_nominal"),
    "calibrated": hex_color("dd_calibrated"),
}
_MM = 1e3
_GRID = (190, 190, 190)  # light grey, thin: under the paths (the truth is a darker grey, wider)
_GRID_TEXT = (110, 110, 110)
_PATH_WIDTH = {"truth": -2.5}  # ui points; the dead-reckoned paths: rerun's default (1 point)


def _path_name(name: str) -> str:
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in Path(name).stem) or "run"


def _run_label(result: AnalysisResult) -> str:
    """``run <file name>`` of a one-run result (``run`` when it names no file)."""
    path = str(result.source.get("path", "") or "")
    return f"run {Path(path).name}" if path else "run"


def _trajectories(result: AnalysisResult) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = result.artifacts.get("trajectories", {}) or {}
    return out


def _methods(result: AnalysisResult) -> list[CalibrationResult]:
    return [m for m in result.methods if isinstance(m, CalibrationResult)]


def _table(result: AnalysisResult, start_ns: int | None = None) -> str:
    """Markdown: each method's parameters (mm) ± one standard error and 95 % interval; then the
    log's absolute start (``start_ns``: the timeline's zero), once."""
    methods = _methods(result)
    names = sorted({n for m in methods for n in m.parameters})
    lines = [
        "| method | " + " | ".join(f"{n} (mm)" for n in names) + " |",
        "|---|" + "---|" * len(names),
    ]
    for m in methods:
        cells = []
        for n in names:
            e = m.parameters.get(n)
            if e is None or not math.isfinite(e.value):
                cells.append("–")
            elif not e.identifiable or not all(math.isfinite(v) for v in e.ci95):
                cells.append(f"{e.value * _MM:.3f} (not determined)")
            else:
                cells.append(
                    f"{e.value * _MM:.3f} ± {e.std * _MM:.3f} "
                    f"[{e.ci95[0] * _MM:.3f}, {e.ci95[1] * _MM:.3f}]"
                )
        lines.append(f"| {m.method} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(PM_MEANING)
    if start_ns is not None:
        lines += ["", f"Time: seconds from the log's start, {start_words(start_ns)}."]
    return "\n".join(lines)


def grid_lines(paths: dict[str, Any]) -> tuple[float, list[float], list[float]]:
    """A metric grid over the paths' extent: (spacing m, x of the vertical lines, y of the
    horizontal ones), spacing 0.1, 0.2, 0.5, 1, 2, 5 ... m for 2 to 10 lines a side."""
    xs = np.concatenate([np.asarray(a["x"], dtype=float) for a in paths.values()] or [np.zeros(0)])
    ys = np.concatenate([np.asarray(a["y"], dtype=float) for a in paths.values()] or [np.zeros(0)])
    xs, ys = xs[np.isfinite(xs)], ys[np.isfinite(ys)]
    if xs.size == 0 or ys.size == 0:
        return 1.0, [], []
    span = max(float(np.ptp(xs)), float(np.ptp(ys)), 1e-3)
    steps = [m * 10.0**e for e in range(-2, 4) for m in (1.0, 2.0, 5.0)]
    step = next(s for s in steps if span / s <= 8)

    def ticks(v: np.ndarray) -> list[float]:
        lo, hi = math.floor(v.min() / step), math.ceil(v.max() / step)
        return [round(k * step, 10) for k in range(lo, hi + 1)]

    return step, ticks(xs), ticks(ys)


def grid_labels(gx: list[float], gy: list[float]) -> tuple[list[list[float]], list[str]]:
    """Where the grid's coordinates are written, and what: ``x … m`` under each vertical line
    (on the lowest horizontal one), ``y … m`` beside each horizontal line (on the leftmost
    vertical one); the corner, where both meet, gets one label naming both."""
    anchors = [[gx[0], gy[0]]] + [[x, gy[0]] for x in gx[1:]] + [[gx[0], y] for y in gy[1:]]
    labels = [f"x {gx[0]:g} m, y {gy[0]:g} m"]
    labels += [f"x {x:g} m" for x in gx[1:]] + [f"y {y:g} m" for y in gy[1:]]
    return anchors, labels


def _log_grid(rec: rr.RecordingStream, path: str, paths: dict[str, Any]) -> None:
    """Grid lines (thin light grey) with their coordinates in metres: the 2D view's scale."""
    _, gx, gy = grid_lines(paths)
    if not gx or not gy:
        return
    lines = [[[x, gy[0]], [x, gy[-1]]] for x in gx] + [[[gx[0], y], [gx[-1], y]] for y in gy]
    rec.log(path, rr.LineStrips2D(lines, colors=[_GRID], radii=[-0.5]), static=True)
    anchors, labels = grid_labels(gx, gy)
    rec.log(
        f"{path}/labels",
        rr.Points2D(anchors, labels=labels, colors=[_GRID_TEXT], radii=[-1.0]),
        static=True,
    )


def _run_bounds(paths: dict[str, Any]) -> rrb.VisualBounds2D | None:
    """The run's grid with a margin of one grid step for its labels, y up
    (:func:`viz.style.y_up_bounds`)."""
    step, gx, gy = grid_lines(paths)
    if not gx or not gy:
        return None
    xr, yr = y_up_bounds((gx[0] - step, gx[-1] + step), (gy[0] - step, gy[-1] + step))
    return rrb.VisualBounds2D(x_range=xr, y_range=yr)


def log_views(
    out: Path, loaded: LoadedLike, result: AnalysisResult, options: object = None
) -> Path:
    """Write the .rrd to ``out`` (a view per run and the methods table) and return it; the
    differential drive has no options of its own and draws what ``result`` carries.

    A pooled ``result`` (its ``runs`` set) draws every run's paths and the pooled methods, not
    ``loaded``'s raw signals (they are one run's); each recording has its own application id
    (``viz.style.application_id``) so that rerun shows each through its own layout."""
    out = Path(out)
    rec = rr.RecordingStream(application_id(result))
    rec.save(out)
    views: list[rrb.View] = []
    try:
        y_up(rec, "world")  # rerun's 2D views draw y down: the paths must read with y up
        for run_name, paths in _trajectories(result).items():
            base = f"world/{_path_name(run_name)}"
            _log_grid(rec, f"{base}/grid", paths)
            for label, arr in paths.items():
                xy = np.column_stack([np.asarray(arr["x"]), np.asarray(arr["y"])])
                ok = np.all(np.isfinite(xy), axis=1)
                if not ok.any():
                    continue
                colour = _COLOURS.get(label, (0, 0, 0))
                rec.log(
                    f"{base}/{label}",
                    rr.LineStrips2D(
                        [xy[ok]], colors=[colour], radii=[_PATH_WIDTH.get(label, -1.0)]
                    ),
                    static=True,
                )
                rec.log(  # where the path ends: where the drift shows
                    f"{base}/{label}_end",
                    rr.Points2D([xy[ok][-1]], colors=[colour], radii=[-4.0]),
                    static=True,
                )
            views.append(
                rrb.Spatial2DView(
                    name=f"run {Path(run_name).name}: grey truth, vermillion nominal, "
                    "blue calibrated (dead reckoning; dots: end points; grid in m, y up)",
                    origin="/",  # the mirror at world/ applies (not above a view's origin)
                    contents=[f"+ /{base}/**"],
                    visual_bounds=_run_bounds(paths),
                )
            )
        start = int(loaded.frame["t_ns"][0]) if loaded.frame.height and not result.runs else None
        rec.log(
            "methods",
            rr.TextDocument(_table(result, start), media_type="text/markdown"),
            static=True,
        )
        if not result.runs:
            origin = int(loaded.frame["t_ns"][0]) if loaded.frame.height else None
            log_raw_signals(rec, loaded.log.topics, timeline=TIMELINE, origin_ns=origin)
    finally:
        rec.flush()
    which = f"pooled over {len(result.runs)} runs" if result.runs else _run_label(result)
    grid = rrb.Grid(*views[:6]) if views else rrb.TextDocumentView(origin="methods")
    rec.send_blueprint(
        rrb.Blueprint(
            rrb.Vertical(
                grid,
                rrb.Tabs(
                    rrb.TextDocumentView(
                        name=f"methods, {which}: parameters (mm)", origin="methods"
                    ),
                    *raw_views({} if result.runs else loaded.log.topics),
                ),
                row_shares=[3, 1],
            ),
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="collapsed"),
        )
    )
    rec.flush()
    rec.disconnect()
    return out


def report_figure(result: AnalysisResult) -> Figure:
    """The report image's figure (see :func:`write_png`), for saving or for checking."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = list(_trajectories(result).items())[:6]
    methods = _methods(result)
    names = sorted({n for m in methods for n in m.parameters})
    fig = plt.figure(figsize=(16, 9), dpi=100)
    outer = fig.add_gridspec(2, 1, height_ratios=[3, 2], hspace=0.35)
    top = outer[0].subgridspec(1, max(1, len(runs)))  # the runs fill the top row
    bottom = outer[1].subgridspec(1, max(1, len(names)), wspace=0.45)  # the parameters, below
    for i, (run_name, paths) in enumerate(runs):
        ax = fig.add_subplot(top[0, i])
        for label, arr in paths.items():
            width = 2.8 if label == "truth" else 1.2  # under the others, still seen where they meet
            ax.plot(arr["x"], arr["y"], color=_PNG_COLOURS.get(label, "k"), lw=width, label=label)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(Path(run_name).name, fontsize=9)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        if i == 0:
            ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.15), ncol=3, fontsize=8)
    for j, name in enumerate(names):
        ax = fig.add_subplot(bottom[0, j])
        _parameter_panel(ax, result, methods, name)
        if j == 0 and ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.25), ncol=3, fontsize=8)
    fig.suptitle(f"differential drive: {len(runs)} run(s), {len(methods)} method(s)")
    return fig


def _determined(e: Estimate) -> bool:
    """As the table says (:func:`_table`): identifiable with a finite 95 % interval."""
    return e.identifiable and all(math.isfinite(v) for v in e.ci95) and math.isfinite(e.value)


def _parameter_panel(
    ax: Axes, result: AnalysisResult, methods: list[CalibrationResult], name: str
) -> None:
    """Each method's ``name`` (mm) with its 95 % interval; "not determined" written where the
    table writes it; the nominal and true values as vertical lines."""
    rows = [(m.method, m.parameters[name]) for m in methods if name in m.parameters]
    for k, (_label, e) in enumerate(rows):
        if _determined(e):
            lo, hi = e.ci95
            ax.errorbar(
                [e.value * _MM],
                [k],
                xerr=[[(e.value - lo) * _MM], [(hi - e.value) * _MM]],
                fmt="o",
                color=hex_color("dd_calibrated"),
                capsize=3,
            )
        elif math.isfinite(e.value):
            ax.plot([e.value * _MM], [k], "x", color="0.4")
            ax.annotate(
                f"{e.value * _MM:.3f} (not determined)",
                (e.value * _MM, k),
                xytext=(6, 4),
                textcoords="offset points",
                fontsize=8,
                color="0.3",
            )
    for key, style, what in (("nominal", "--", "nominal"), ("truth", "-", "truth")):
        ref = (result.sections.get(key) if key == "nominal" else result.truth) or {}
        if isinstance(ref, dict) and math.isfinite(float(ref.get(name, math.nan))):
            ax.axvline(float(ref[name]) * _MM, ls=style, color="k", lw=0.8, label=what)
    ax.set_yticks(range(len(rows)), [r[0] for r in rows], fontsize=8)
    ax.set_ylim(-0.5, len(rows) - 0.5)
    ax.set_xlabel(f"{name} (mm); bars: 95 % interval")
    ax.grid(axis="x", alpha=0.3)


def write_png(out: Path, loaded: LoadedLike, result: AnalysisResult) -> Path:
    """Static report image: up to six runs' paths (truth, nominal, calibrated dead reckoning)
    across the top, and one panel per parameter below (each method's value and 95 % interval,
    mm; "not determined" written where the table writes it)."""
    import matplotlib.pyplot as plt

    fig = report_figure(result)
    fig.savefig(out)
    plt.close(fig)
    return out
