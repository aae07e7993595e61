"""Per-method error bars (value +/- std over repeats, truth line) and the methods table.

Rerun has no error-bar plot, so each (segment type, parameter) gets a 2D forest plot: x is the
link length (m), y a layout slot per method (first method on top, as rerun's 2D views point y
down). Every entry is static.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import rerun as rr
from numpy.typing import ArrayLike

from calib.results import AnalysisResult, MethodResult, format_pm
from viz.style import COLORS

__all__ = [
    "METHODS",
    "PARAMS",
    "ForestLayout",
    "forest_layout",
    "log_methods",
    "methods_table",
    "robust_range",
    "segment_types",
]

METHODS = "methods"
PARAMS = ("L1", "L2")


def segment_types(result: AnalysisResult) -> list[str]:
    """Segment labels of the method rows, "all" first, then in order of appearance."""
    seen: list[str] = []
    for m in result.methods:
        if m.segment not in seen:
            seen.append(m.segment)
    return sorted(seen, key=lambda s: s != "all")


def _std(x: float) -> float:
    return 0.0 if not math.isfinite(x) else float(x)


def _label(m: MethodResult) -> str:
    cn = m.condition_number
    return m.name if not math.isfinite(cn) else f"{m.name}  cond {cn:.3g}"


@dataclass(frozen=True)
class ForestLayout:
    """Layout of one forest plot: row spacing ``dy`` and the robust view bounds (m)."""

    dy: float
    x_range: tuple[float, float]
    y_range: tuple[float, float]


def robust_range(values: ArrayLike, truth: float | None = None) -> tuple[float, float]:
    """Range (m) of the values within 8 robust standard deviations (1.4826 MAD) of their
    median, and ``truth``, padded 10 %: wild estimates of ill-conditioned methods (up to half
    of them) fall outside."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    pts = [] if truth is None or not math.isfinite(truth) else [truth]
    if v.size:
        med = float(np.median(v))
        scale = 1.4826 * float(np.median(np.abs(v - med)))
        kept = v[np.abs(v - med) <= 8.0 * scale] if scale > 0 else v[v == med]
        pts += [float(kept.min()), float(kept.max())]
    if not pts:
        return (0.0, 1.0)
    lo, hi = min(pts), max(pts)
    pad = 0.1 * max(hi - lo, 1e-3)
    return (lo - pad, hi + pad)


def forest_layout(rows: list[MethodResult], param: str, truth: float | None) -> ForestLayout:
    """Row spacing and view bounds of the forest plot of ``param`` over ``rows``."""
    vals = np.array([getattr(m, param) for m in rows], dtype=float)
    sds = np.array([_std(getattr(m, f"{param}_std")) for m in rows])
    x_range = robust_range(np.concatenate([vals - sds, vals + sds]), truth)
    n = max(len(rows), 4)
    dy = (x_range[1] - x_range[0]) / n
    return ForestLayout(dy, x_range, (-dy, len(rows) * dy))


def _log_forest(
    rec: rr.RecordingStream, path: str, rows: list[MethodResult], param: str, truth: float | None
) -> None:
    """``path/value`` points, ``path/bar`` horizontal +/- std bars, ``path/truth`` line."""
    vals = np.array([getattr(m, param) for m in rows], dtype=float)
    sds = np.array([_std(getattr(m, f"{param}_std")) for m in rows])
    ok = np.isfinite(vals)
    if not ok.any():
        return
    dy = forest_layout(rows, param, truth).dy
    ys = np.arange(len(rows)) * dy
    color = COLORS[param]
    rec.log(
        f"{path}/value",
        rr.Points2D(
            np.stack([vals[ok], ys[ok]], axis=-1),
            labels=[_label(m) for m, k in zip(rows, ok, strict=True) if k],
            colors=[color],
            radii=[0.08 * dy],
        ),
        static=True,
    )
    bars = [
        np.array([[v - s, y], [v + s, y]])
        for v, s, y in zip(vals[ok], sds[ok], ys[ok], strict=True)
    ]
    rec.log(f"{path}/bar", rr.LineStrips2D(bars, colors=[color], radii=[0.05 * dy]), static=True)
    if truth is not None and math.isfinite(truth):
        line = np.array([[truth, -dy], [truth, ys[-1] + dy]])
        rec.log(
            f"{path}/truth",
            rr.LineStrips2D(
                [line], colors=[COLORS["truth"]], radii=[0.06 * dy], labels=[f"true {param}"]
            ),
            static=True,
        )


def log_methods(rec: rr.RecordingStream, result: AnalysisResult) -> list[str]:
    """Log ``methods/<segment>/<L1|L2>/{value,bar,truth}`` and ``methods/table``.

    Returns:
        The segment labels logged, "all" first.
    """
    segs = segment_types(result)
    for seg in segs:
        rows = [m for m in result.methods if m.segment == seg]
        for param in PARAMS:
            _log_forest(rec, f"{METHODS}/{seg}/{param}", rows, param, result.truth.get(param))
    if result.methods:
        rec.log(
            f"{METHODS}/table",
            rr.TextDocument(methods_table(result), media_type="text/markdown"),
            static=True,
        )
    return segs


def _pm(v: float, s: float) -> str:
    return format_pm(v, s, digits=4)


def methods_table(result: AnalysisResult) -> str:
    """Markdown table: every method row with L1, L2 (m) ± spread over repeats and condition
    number (± as ``calib.results.PM_MEANING`` says)."""
    lines = []
    if result.truth:
        lines.append(
            "Truth: " + ", ".join(f"{k} = {v:.4g}" for k, v in result.truth.items()) + "\n"
        )
    lines += [
        "| segment | family | method | L1 (m) | L2 (m) | condition number | repeats |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in result.methods:
        lines.append(
            f"| {m.segment} | {m.family} | {m.name} | {_pm(m.L1, m.L1_std)} | "
            f"{_pm(m.L2, m.L2_std)} | {_pm(m.condition_number, m.condition_number_std)} | "
            f"{m.n_repeats} |"
        )
    return "\n".join(lines)
