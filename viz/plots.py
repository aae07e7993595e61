"""Static PNG of the main views (matplotlib), for reports and people without the viewer."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import polars as pl
from numpy.typing import NDArray

from calib.results import AnalysisResult
from calib.tractor_trailer.views_data import VIEWS
from viz._frame import column, has, robust_limits, times_ns
from viz.methods import PARAMS, robust_range, segment_types
from viz.style import hex_color

__all__ = ["write_report_png"]


def _world(ax, frame: pl.DataFrame, c: Mapping[str, np.ndarray]) -> None:
    ax.set_title("World: paths, robot and ICR (last sample with a turn)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if not has(frame, "x", "y"):
        ax.text(0.5, 0.5, "no pose in this log", ha="center", transform=ax.transAxes)
        return
    x, y = column(frame, "x"), column(frame, "y")
    if "P" not in c:
        ax.plot(x, y, color=hex_color("C1"), lw=1, label="C1")
        ax.legend(loc="best", fontsize=8)
        return
    for name in ("C2", "P", "C1"):
        ax.plot(c[name][:, 0], c[name][:, 1], color=hex_color(name), lw=1.2, label=name)
    idx = np.flatnonzero(c["icr_valid"])
    if idx.size:
        i = int(idx[-1])
        c1, p, c2 = c["C1"][i], c["P"][i], c["C2"][i]
        o, q = c["O"][i], c["Q"][i]
        ax.plot(*np.stack([c1, p, c2]).T, color="k", lw=2.5, label="links")
        ax.plot(*np.stack([o, q, c2, o]).T, color=hex_color("triangle_OQC2"), lw=1, label="O Q C2")
        ax.plot(
            *np.stack([q, c1, p, q]).T,
            color=hex_color("triangle_QC1P"),
            lw=1,
            label="Q C1 P",
        )
        ax.plot(*o, "o", color=hex_color("O"), label=f"O (R = {c['R'][i]:.2f} m)")
        ax.plot(*q, "o", color=hex_color("Q"), label="Q")
    ax.legend(loc="best", fontsize=7)


def _robust_ylim(ax, *series: NDArray[np.float64]) -> None:
    lim = robust_limits(*series)
    if lim is not None:
        ax.set_ylim(*lim)


def _segment_marks(ax, result: AnalysisResult, labels: bool) -> None:
    for s in result.segments:
        ax.axvline(s.start_s, color="0.6", lw=0.6)
        if labels:
            ax.text(
                s.start_s,
                1.0,
                f" {s.command_type}",
                transform=ax.get_xaxis_transform(),
                fontsize=7,
                va="bottom",
                color="0.3",
            )


def _kappa(
    ax,
    frame: pl.DataFrame,
    result: AnalysisResult,
    t: NDArray[np.float64],
    views: Mapping[str, np.ndarray],
) -> None:
    ax.set_ylabel("κ (1/m)")
    shown = []
    if has(frame, "kappa_cmd"):
        shown.append(column(frame, "kappa_cmd"))
        ax.plot(t, shown[-1], color=hex_color("kappa_cmd"), lw=2.8, label="κ command")
    kappa = views.get("kappa")
    if kappa is not None:
        shown.append(kappa)
        ax.plot(t, kappa, color=hex_color("kappa"), lw=0.8, label="κ measured")
    _robust_ylim(ax, *shown)
    _segment_marks(ax, result, labels=True)
    if shown:
        ax.legend(loc="lower left", fontsize=7)


def _psi(
    ax,
    frame: pl.DataFrame,
    result: AnalysisResult,
    t: NDArray[np.float64],
    views: Mapping[str, np.ndarray],
) -> None:
    ax.set_ylabel("ψ (rad)")
    ax.set_xlabel("time since start (s)")
    shown = []
    if has(frame, "psi"):
        shown.append(column(frame, "psi"))
        ax.plot(t, shown[-1], color=hex_color("psi"), lw=1, label="ψ measured")
    if "psi_steady" in views:
        label = "ψ steady state at " + (
            "the true L1, L2" if result.estimate is None else f"{result.estimate.method}'s L1, L2"
        )
        ax.plot(
            t,
            views["psi_steady"],
            color=hex_color("psi_estimate"),
            lw=1,
            ls="--",
            label=label,
        )
    _robust_ylim(ax, *shown)
    _segment_marks(ax, result, labels=False)
    ax.legend(loc="lower left", fontsize=7)


def _forest(ax, result: AnalysisResult, param: str) -> None:
    """value +/- std per method, one colour per segment type, truth as a vertical line."""
    ax.set_title(f"{param} per method (m), ± std over repeats")
    segs = segment_types(result)
    cmap = ["k", "tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"]
    names = list(dict.fromkeys(m.name for m in result.methods))
    for j, seg in enumerate(segs):
        rows = [m for m in result.methods if m.segment == seg]
        ys = [names.index(m.name) + 0.8 * j / max(len(segs), 1) for m in rows]
        ax.errorbar(
            [getattr(m, param) for m in rows],
            ys,
            xerr=[np.nan_to_num(getattr(m, f"{param}_std")) for m in rows],
            fmt="o",
            ms=3,
            lw=1,
            color=cmap[j % len(cmap)],
            label=seg,
        )
    truth = result.truth.get(param)
    if truth is not None:
        ax.axvline(truth, color="0.4", ls="--", lw=1, label="truth")
    vals = np.array([getattr(m, param) for m in result.methods], dtype=float)
    sds = np.nan_to_num(np.array([getattr(m, f"{param}_std") for m in result.methods], dtype=float))
    lo, hi = robust_range(np.concatenate([vals - sds, vals + sds]), truth)
    ax.set_xlim(lo, hi)
    off = int(np.sum(np.isfinite(vals) & ((vals < lo) | (vals > hi))))
    if off:
        ax.set_xlabel(f"{off} estimate(s) outside the plotted range (ill-conditioned)")
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.invert_yaxis()
    if names:
        ax.legend(loc="best", fontsize=7)


def write_report_png(
    path: str | Path,
    frame: pl.DataFrame,
    result: AnalysisResult,
    views: Mapping[str, np.ndarray] | None = None,
    *,
    dpi: int = 110,
) -> Path:
    """Save world + ICR, kappa/psi series and per-method error bars as one PNG.

    Args:
        path: output .png (parent directories are created).
        frame: aligned log (``t_ns`` and whatever signals exist).
        result: the analysis.
        views: the arrays drawn (``calib.tractor_trailer.views_data.tractor_views_data``);
            None takes them from ``result.artifacts["views"]``.
        dpi: resolution (dots per inch) of the 14 x 9 inch figure.

    Returns:
        The path written.
    """
    from matplotlib.figure import Figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    drawn: Mapping[str, np.ndarray] = (
        result.artifacts.get(VIEWS, {}) if views is None else views
    )
    fig = Figure(figsize=(14, 9), layout="constrained")
    axes = fig.subplot_mosaic(
        [["world", "kappa"], ["world", "psi"], ["L1", "L2"], ["L1", "L2"]],
        gridspec_kw={"height_ratios": [1, 1, 1, 1]},
    )
    _world(axes["world"], frame, drawn)
    if frame.height:
        t = (times_ns(frame) - times_ns(frame)[0]) / 1e9
        _kappa(axes["kappa"], frame, result, t, drawn)
        _psi(axes["psi"], frame, result, t, drawn)
    for p in PARAMS:
        _forest(axes[p], result, p)
    fig.suptitle(
        result.robot
        + ("" if result.estimate is None else f" — recommended: {result.estimate.method}")
    )
    fig.savefig(out, dpi=dpi)
    return out
