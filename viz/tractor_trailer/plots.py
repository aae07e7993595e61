"""Static PNG of the main views (matplotlib), for reports and people without the viewer."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
from numpy.typing import NDArray

from calib.results import PM_MEANING, AnalysisResult
from calib.tractor_trailer.views_data import VIEWS
from viz._frame import column, has, robust_limits, times_ns
from viz.style import hex_color
from viz.tractor_trailer.blueprint import follow_half_width
from viz.tractor_trailer.methods import (
    PARAMS,
    ForestRow,
    forest_rows,
    recommended_values,
    robust_range,
    zoom_range,
)
from viz.tractor_trailer.signals import psi_curve_names

__all__ = ["write_report_png"]


def _outside_legend(ax, below: bool = False) -> None:
    """A legend right of (or below) the axes, where it covers no data; nothing when no artist
    is labelled."""
    if not ax.get_legend_handles_labels()[0]:
        return
    if below:  # 34 points under the axes: below its tick labels and its x label
        from matplotlib.transforms import ScaledTranslation

        under = ax.transAxes + ScaledTranslation(0, -34 / 72, ax.figure.dpi_scale_trans)
        ax.legend(
            loc="upper center",
            bbox_to_anchor=(0.5, 0.0),
            bbox_transform=under,
            fontsize=7,
            frameon=False,
            ncol=2,
        )
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)


def _last_turn(c: Mapping[str, np.ndarray]) -> int | None:
    idx = np.flatnonzero(np.asarray(c.get("icr_valid", []), dtype=bool))
    return int(idx[-1]) if idx.size else None


def _world(ax, frame: pl.DataFrame, c: Mapping[str, np.ndarray]) -> None:
    ax.set_title("World: whole path", fontsize=10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if not has(frame, "x", "y"):
        ax.text(0.5, 0.5, "no pose in this log", ha="center", transform=ax.transAxes)
        return
    x, y = column(frame, "x"), column(frame, "y")
    if "P" not in c:
        ax.plot(x, y, color=hex_color("C1"), lw=1, label="C1")
        _outside_legend(ax, below=True)
        return
    for name in ("C2", "P", "C1"):
        ax.plot(c[name][:, 0], c[name][:, 1], color=hex_color(name), lw=1.0, label=name)
    i = _last_turn(c)
    if i is not None:
        ax.plot(*c["C1"][i], "s", ms=7, mfc="none", color="k", label="close-up (right)")
    _outside_legend(ax, below=True)


def _icr_closeup(ax, c: Mapping[str, np.ndarray], half: float | None) -> None:
    """The robot and the ICR construction at the last sample with a turn, around C1."""
    i = _last_turn(c)
    if i is None or half is None:
        ax.set_axis_off()
        ax.text(0.5, 0.5, "no turn: no ICR construction", ha="center", transform=ax.transAxes)
        return
    c1, p, c2, o, q = (c[k][i] for k in ("C1", "P", "C2", "O", "Q"))
    ax.set_title("ICR at the last turn (around C1)", fontsize=10)
    ax.set_aspect("equal")
    for name in ("C2", "P", "C1"):
        ax.plot(c[name][:, 0], c[name][:, 1], color=hex_color(name), lw=0.8, alpha=0.6)
    ax.plot(*np.stack([c1, p, c2]).T, color="k", lw=2.5, label="links C1–P–C2")
    ax.plot(
        *np.stack([o, q, c2, o]).T,
        color=hex_color("triangle_OQC2"),
        lw=1.2,
        label="triangle O Q C2",
    )
    ax.plot(
        *np.stack([q, c1, p, q]).T,
        color=hex_color("triangle_QC1P"),
        lw=1.2,
        label="triangle Q C1 P",
    )
    ax.plot(
        *np.stack([o, c1]).T,
        color=hex_color("radius"),
        lw=0.8,
        ls=":",
        label=f"radius O C1, R = {c['R'][i]:.2f} m",
    )
    for name, pt in (("C1", c1), ("P", p), ("C2", c2), ("O", o), ("Q", q)):
        color = hex_color(name)
        ax.plot(*pt, "o", color=color, ms=6)
        ax.annotate(name, pt, xytext=(5, 5), textcoords="offset points", fontsize=8, color="k")
    ax.set_xlim(c1[0] - half, c1[0] + half)
    ax.set_ylim(c1[1] - half, c1[1] + half)
    ax.set_xlabel("x (m)")
    _outside_legend(ax, below=True)


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
                rotation=25,
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
    _outside_legend(ax)


def _psi(
    ax,
    frame: pl.DataFrame,
    result: AnalysisResult,
    t0_ns: int,
    views: Mapping[str, np.ndarray],
) -> None:
    ax.set_ylabel("ψ (rad)")
    ax.set_xlabel("time since start (s)")
    t = (times_ns(frame) - t0_ns) / 1e9
    shown = []
    names = psi_curve_names(result, views)
    if has(frame, "psi"):
        shown.append(column(frame, "psi"))
        ax.plot(t, shown[-1], color=hex_color("psi"), lw=2.2, label="ψ measured")
    if "psi_model" in names:
        tm = (np.asarray(views["psi_model_t_ns"], dtype=np.int64) - t0_ns) / 1e9
        ax.plot(
            tm,
            views["psi_model"],
            color=hex_color("psi_estimate"),
            lw=1.0,
            label=_wrap(names["psi_model"]),
        )
    if "psi_steady" in names:
        ax.plot(
            t,
            views["psi_steady"],
            color=hex_color("psi_steady"),
            lw=0.9,
            ls="--",
            label=_wrap(names["psi_steady"]),
        )
    _robust_ylim(ax, *shown)
    _segment_marks(ax, result, labels=False)
    _outside_legend(ax)


def _wrap(text: str, width: int = 38) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


_APART_STEP = 0.45
"""Row spacing of the set-apart (grey, not to be read) rows, as a fraction of a read row's."""


def row_positions(apart: list[bool]) -> NDArray[np.float64]:
    """y of each error-bar row: read rows one unit apart, set-apart rows ``_APART_STEP`` apart
    (they are many and not to be read: they must not take the panel from the read ones)."""
    steps = [(_APART_STEP if a else 1.0) for a in apart]
    ys = np.zeros(len(apart))
    for i in range(1, len(apart)):
        ys[i] = ys[i - 1] + (steps[i - 1] + steps[i]) / 2
    return ys


def _forest(ax, rows: list[ForestRow], result: AnalysisResult, param: str, *, zoom: bool) -> None:
    """value ± std per row; set-apart rows grey below a divider; truth and recommended
    value as vertical lines; the x range all rows' bulk, or zoomed on the recommended."""
    truth = result.truth.get(param)
    rec = recommended_values(result)
    apart = [r.apart is not None for r in rows]
    ys = row_positions(apart)
    vals = np.array([r.value(param) for r in rows])
    sds = np.array([r.std(param) for r in rows])
    det = ~np.array(apart, dtype=bool)
    if zoom and param in rec:
        lo, hi = zoom_range(rec[param][0], rec[param][1], truth, rows, param)
        ax.set_title(f"{param} (m) zoomed", fontsize=9)
    else:
        extra = [rec[param][0]] if param in rec else []
        lo, hi = robust_range(
            np.concatenate([vals[det] - sds[det], vals[det] + sds[det], extra]), truth
        )
        ax.set_title(f"{param} (m), all methods", fontsize=9)
    for k, color in ((det, hex_color(param)), (~det, "0.6")):
        ax.errorbar(vals[k], ys[k], xerr=sds[k], fmt="o", ms=3, lw=1, color=color)
    if truth is not None:
        ax.axvline(truth, color="k", ls="--", lw=1, label=f"truth {param} = {truth:.4g} m")
    if param in rec and result.estimate is not None:
        ax.axvline(
            rec[param][0],
            color=hex_color("psi_estimate"),
            lw=1.2,
            label=f"recommended ({result.estimate.method}) {rec[param][0]:.4g} m",
        )
    ax.set_xlim(lo, hi)
    first_apart = next((i for i, a in enumerate(apart) if a), None)
    bottom = float(ys[-1]) + (_APART_STEP if apart[-1] else 1.0) / 2 if len(ys) else 0.5
    if first_apart is not None:
        ax.axhspan(float(ys[first_apart]) - _APART_STEP / 2, bottom, color="0.92", zorder=0)
    if not zoom:
        for y, v in zip(ys[det], vals[det], strict=True):
            if np.isfinite(v) and not lo <= v <= hi:
                ax.annotate(
                    ("◀ " if v < lo else "▶ ") + f"{v:.3g}",
                    (lo if v < lo else hi, y),
                    ha="left" if v < lo else "right",
                    va="center",
                    fontsize=6,
                )
    labels = [r.label if r.apart is None else f"{r.label} ({r.apart})" for r in rows]
    ax.set_yticks(ys, labels if not zoom else [""] * len(rows), fontsize=8)
    for tick, a in zip(ax.get_yticklabels(), apart, strict=True):
        tick.set_color("0.45" if a else "k")
        tick.set_fontsize(5.5 if a else 8)
    ax.set_ylim(bottom, -0.5)
    ax.grid(axis="x", color="0.85", lw=0.5)


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
        dpi: resolution (dots per inch) of the 16 x 10 inch figure.

    Returns:
        The path written.
    """
    from matplotlib.figure import Figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    drawn: Mapping[str, np.ndarray] = result.artifacts.get(VIEWS, {}) if views is None else views
    fig = Figure(figsize=(16, 10), layout="constrained")
    axes = fig.subplot_mosaic(
        [
            ["world", "close", "kappa", "kappa"],
            ["world", "close", "psi", "psi"],
            ["L1", "L1z", "L2", "L2z"],
            ["L1", "L1z", "L2", "L2z"],
        ],
        height_ratios=[1, 1, 1.1, 1.1],
        width_ratios=[1, 0.8, 1, 0.8],
    )
    _world(axes["world"], frame, drawn)
    _icr_closeup(axes["close"], drawn, follow_half_width(drawn))
    if frame.height:
        t0 = int(times_ns(frame)[0])
        _kappa(axes["kappa"], frame, result, (times_ns(frame) - t0) / 1e9, drawn)
        _psi(axes["psi"], frame, result, t0, drawn)
    rows = forest_rows([m for m in result.methods if m.segment == "all"])
    for p in PARAMS:
        for key, zoom in ((p, False), (f"{p}z", True)):
            if rows:
                _forest(axes[key], rows, result, p, zoom=zoom)
            else:
                axes[key].set_axis_off()
    handles: dict[str, Any] = {}
    for key in ("L1", "L2"):
        for h, lab in zip(*axes[key].get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    if handles:
        fig.legend(
            list(handles.values()),
            list(handles.keys()),
            loc="outside lower center",
            ncol=len(handles),
            fontsize=8,
            frameon=False,
        )
    fig.suptitle(
        result.robot
        + ("" if result.estimate is None else f" — recommended: {result.estimate.method}")
        + "\nerror bars: value ± 1 std; grey rows: L1/L2 split not to be read.  "
        + PM_MEANING,
        fontsize=10,
    )
    fig.savefig(out, dpi=dpi)
    return out
