"""rerun views of an arm analysis: the arm drawn moving (forward-kinematics points carried in the
result), measured vs predicted torque per joint on the held-out part, and the parameter
convergence of the recursive estimators. Draws only what ``result.artifacts`` carries."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from calib.results import AnalysisResult
from viz.loaded import LoadedLike
from viz.raw import log_raw_signals, raw_views
from viz.style import COLORS, TIMELINE, application_id, hex_color, start_words, ui_points

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["log_views", "parameter_lines", "report_figure", "write_png"]

_LINK = ui_points(3.0)  # screen points: the arm reads at any camera distance
_JOINT = ui_points(6.0)


def log_views(
    out: Path,
    loaded: LoadedLike,
    result: AnalysisResult,
    options: object = None,
) -> Path:
    """Save the arm's views of ``result`` to ``out`` (.rrd), with the signals as read from
    ``loaded`` under ``raw/``; ``options`` are
    unused (the arrays drawn are in ``result.artifacts``, computed with the options)."""
    art = result.artifacts
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(application_id(result))
    rec.save(out)
    try:
        start = int(loaded.frame["t_ns"][0]) if loaded.frame.height else None
        rec.log(
            "summary",
            rr.TextDocument(_summary(result, start), media_type="text/markdown"),
            static=True,
        )
        if "points" in art:
            for t, pts in zip(art["t_s"], art["points"], strict=True):
                rec.set_time(TIMELINE, duration=float(t))
                rec.log(
                    "arm/links",
                    rr.LineStrips3D([pts], colors=[COLORS["arm_links"]], radii=[_LINK]),
                )
                rec.log(
                    "arm/joints", rr.Points3D(pts, radii=[_JOINT], colors=[COLORS["arm_joints"]])
                )
        names = art.get("joint_names", [])
        if "holdout_t_s" in art:
            meas, pred = art["holdout_measured"], art["holdout_predicted"]
            for name in names:
                for what, label in (("measured", "measured"), ("predicted", "predicted")):
                    rec.log(
                        f"torque/{name}/{what}",
                        rr.SeriesLines(colors=[COLORS[f"arm_{what}"]], names=[label], widths=[1.5]),
                        static=True,
                    )
            for k, t in enumerate(art["holdout_t_s"]):
                rec.set_time(TIMELINE, duration=float(t))
                for j, name in enumerate(names):
                    rec.log(f"torque/{name}/measured", rr.Scalars(float(meas[k, j])))
                    rec.log(f"torque/{name}/predicted", rr.Scalars(float(pred[k, j])))
        pnames = art.get("parameter_names", [])
        for est, traj in art.get("trajectories", {}).items():
            for k, t in enumerate(art["trajectory_t_s"]):
                rec.set_time(TIMELINE, duration=float(t))
                for p, name in enumerate(pnames):
                    v = float(traj[k, p])
                    if np.isfinite(v):
                        rec.log(f"convergence/{est}/{_safe(name)}", rr.Scalars(v))
        if not result.runs:  # a pooled answer: not one run's signals
            origin = int(loaded.frame["t_ns"][0]) if loaded.frame.height else None
            log_raw_signals(rec, loaded.log.topics, timeline=TIMELINE, origin_ns=origin)
    finally:
        rec.flush()
    torque: list[rrb.View] = [
        rrb.TimeSeriesView(
            name=f"{name}: torque (N·m, held-out 40 %), measured grey, predicted vermillion",
            origin=f"torque/{name}",
        )
        for name in names
    ]
    conv: list[rrb.View] = [
        rrb.TimeSeriesView(name=f"{est}: parameter convergence", origin=f"convergence/{est}")
        for est in art.get("trajectories", {})
    ]
    rec.send_blueprint(
        rrb.Blueprint(
            rrb.Horizontal(
                rrb.Vertical(
                    rrb.Spatial3DView(
                        name="arm (forward kinematics of the logged q)", origin="arm"
                    ),
                    rrb.Tabs(
                        rrb.TextDocumentView(name="summary", origin="summary"),
                        *raw_views({} if result.runs else loaded.log.topics),
                    ),
                ),
                rrb.Vertical(*(torque[:4] or [rrb.TextDocumentView(origin="summary")])),
                *([rrb.Vertical(*conv[:3])] if conv else []),
            ),
            rrb.BlueprintPanel(state="collapsed"),
            rrb.SelectionPanel(state="collapsed"),
            rrb.TimePanel(state="collapsed"),  # as every robot's: the views get the height
        )
    )
    rec.flush()
    rec.disconnect()
    return out


def write_png(out: Path, loaded: LoadedLike, result: AnalysisResult) -> Path:
    """Static report image: held-out torque, measured vs predicted, per joint (up to 8), and the
    recommended estimate's parameters beside them."""
    import matplotlib.pyplot as plt

    fig = report_figure(result)
    fig.savefig(out)
    plt.close(fig)
    return out


def parameter_lines(result: AnalysisResult, limit: int = 30) -> list[str]:
    """The recommended estimate's parameters, one line each exactly as the text report writes
    them (``Estimate.report()``: value ± std unit [95 %], "not determined" where it applies);
    at most ``limit`` lines."""
    est = result.estimate
    if est is None:
        return ["no recommended estimate"]
    lines = [f"recommended estimate ({est.method}):"]
    lines += [e.report() for e in list(est.parameters.values())[:limit]]
    if len(est.parameters) > limit:
        lines.append(f"... and {len(est.parameters) - limit} more (logcal analyze --methods)")
    return lines


def report_figure(result: AnalysisResult) -> Figure:
    """The report image's figure (see :func:`write_png`), for saving or for checking."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    art = result.artifacts
    names = list(art.get("joint_names", []))[:8]
    fig = plt.figure(figsize=(16, 9), dpi=100)
    grid = fig.add_gridspec(max(1, len(names)), 2, width_ratios=[2.2, 1], wspace=0.05)
    axes = [fig.add_subplot(grid[j, 0]) for j in range(max(1, len(names)))]
    for ax in axes[1:]:
        ax.sharex(axes[0])
    if "holdout_t_s" in art:
        t = np.asarray(art["holdout_t_s"])
        meas, pred = np.asarray(art["holdout_measured"]), np.asarray(art["holdout_predicted"])
        for j, name in enumerate(names):
            ax = axes[j]
            ax.plot(t, meas[:, j], color=hex_color("arm_measured"), lw=0.8, label="measured")
            ax.plot(
                t,
                pred[:, j],
                color=hex_color("arm_predicted"),
                lw=1.0,
                label="predicted (identified model)",
            )
            ax.set_ylabel(f"{name}\n(N·m)", fontsize=8)
            if j == 0:
                ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.02), ncol=2, fontsize=8)
        axes[-1].set_xlabel("time (s from the log's start), held-out last 40 % of the log")
    side = fig.add_subplot(grid[:, 1])
    side.axis("off")
    side.text(
        0.05,
        1.0,
        "\n".join(parameter_lines(result)),
        va="top",
        ha="left",
        family="monospace",
        fontsize=7.5,
        wrap=True,
        transform=side.transAxes,
    )
    ratio = result.sections.get("torque_rms_holdout_ratio")
    title = "arm: held-out torque"
    if isinstance(ratio, float) and np.isfinite(ratio):
        title += f" (error RMS {100 * ratio:.1f} % of the torque RMS)"
    fig.suptitle(title)
    return fig


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in name)[:60]


def _summary(result: AnalysisResult, start_ns: int | None = None) -> str:
    """Markdown: robot and joints, the log's absolute start once (the timeline's zero), the
    held-out torque error and the recommended estimate."""
    s = result.sections
    lines = [f"# {result.robot}: {', '.join(s.get('joints', []))}"]
    if start_ns is not None and not result.runs:
        lines.append(f"Time: seconds from the log's start, {start_words(start_ns)}.")
    if "torque_rms_holdout_ratio" in s:
        lines.append(f"Held-out torque error: {100 * s['torque_rms_holdout_ratio']:.1f} % of RMS")
    if result.estimate is not None:
        lines += ["```", result.estimate.report(), "```"]
    return "\n\n".join(lines)
