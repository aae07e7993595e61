"""Per-method error bars (value ± std, truth and recommended lines) and the methods table.

Rerun has no error-bar plot with text axes, so each segment type gets one 2D canvas drawn here
in its own units (not metres): a column of method names, then per parameter a full-range panel
and a panel zoomed on the recommended estimate, each with tick values, the truth (when the log
has it) and the recommended value as vertical lines. Rows whose split of L1 and L2 the data do
not determine (CLS, non-finite, ``split_determined`` False, condition number >= 1e8) are drawn
grey below a divider. Consecutive rows of a family with identical numbers share one line
("M13–M16"). The PNG (``viz.tractor_trailer.plots``) draws the same rows with matplotlib. Every
entry is static.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import rerun as rr
from numpy.typing import ArrayLike

from calib.results import PM_MEANING, AnalysisResult, format_pm
from calib.tractor_trailer.results import MethodResult
from viz.style import COLORS, ui_points

__all__ = [
    "CANVAS_WIDTH",
    "METHODS",
    "PARAMS",
    "ForestRow",
    "canvas_height",
    "forest_rows",
    "log_methods",
    "methods_table",
    "nice_ticks",
    "recommended_values",
    "robust_range",
    "segment_types",
    "set_apart_reason",
    "zoom_range",
]

METHODS = "methods"
PARAMS = ("L1", "L2")
#: Condition number from which a row's split is drawn apart as ill-conditioned.
ILL_CONDITIONED = 1e8
#: Width of a methods canvas (canvas units); its height follows the rows (``canvas_height``).
CANVAS_WIDTH = 100.0
_ROW = 2.0  # canvas units per row
_NAMES = (0.0, 19.0)  # x span of the names column
# x spans of the four panels: L1 full, L1 zoom, L2 full, L2 zoom
_PANELS = ((21.0, 39.0), (41.0, 59.0), (62.0, 80.0), (82.0, 100.0))
GREY = (150, 150, 150)
# Rerun draws a label as coloured text on a light box: text colours are dark.
TEXT = (15, 15, 15)
GREY_TEXT = (105, 105, 105)


def segment_types(result: AnalysisResult) -> list[str]:
    """Segment labels of the method rows, "all" first, then in order of appearance."""
    seen: list[str] = []
    for m in result.methods:
        if m.segment not in seen:
            seen.append(m.segment)
    return sorted(seen, key=lambda s: s != "all")


def _std(x: float) -> float:
    return 0.0 if not math.isfinite(x) else float(x)


def set_apart_reason(m: MethodResult) -> str | None:
    """Why a row is drawn apart (its L1/L2 split is not to be read), or None."""
    if not (math.isfinite(m.L1) and math.isfinite(m.L2)):
        return "not determined"
    if m.flags.get("split_determined") is False:
        return "split not determined"
    if str(m.family) == "CLS":
        return "CLS: split from a Taylor expansion"
    if math.isfinite(m.condition_number) and m.condition_number >= ILL_CONDITIONED:
        return f"ill-conditioned (cond {m.condition_number:.1e})"
    return None


@dataclass(frozen=True)
class ForestRow:
    """One drawn row: consecutive methods of one family with identical numbers share it."""

    label: str
    names: tuple[str, ...]
    L1: float
    L2: float
    L1_std: float
    L2_std: float
    apart: str | None

    def value(self, param: str) -> float:
        return float(getattr(self, param))

    def std(self, param: str) -> float:
        return _std(getattr(self, f"{param}_std"))


def _key(m: MethodResult) -> tuple[object, ...]:
    return (str(m.family), *(f"{getattr(m, k):.4g}" for k in ("L1", "L2", "L1_std", "L2_std")))


def forest_rows(methods: Sequence[MethodResult]) -> list[ForestRow]:
    """The rows of one segment type: determined ones first (in the analysis' order), then the
    set-apart ones; runs of consecutive same-family methods with equal numbers (4 significant
    digits) merged into one row labelled "first–last"."""
    groups: list[list[MethodResult]] = []
    for m in methods:
        if groups and _key(groups[-1][-1]) == _key(m):
            groups[-1].append(m)
        else:
            groups.append([m])
    rows = []
    for g in groups:
        m = g[0]
        label = m.name if len(g) == 1 else f"{g[0].name}–{g[-1].name}"
        rows.append(
            ForestRow(
                label,
                tuple(x.name for x in g),
                m.L1,
                m.L2,
                m.L1_std,
                m.L2_std,
                set_apart_reason(m),
            )
        )
    return [r for r in rows if r.apart is None] + [r for r in rows if r.apart is not None]


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


def recommended_values(result: AnalysisResult) -> dict[str, tuple[float, float]]:
    """(value, std) of the recommended L1, L2 (m) where finite."""
    est = result.estimate
    out: dict[str, tuple[float, float]] = {}
    if est is None:
        return out
    for p in PARAMS:
        e = est.parameters.get(p)
        if e is not None and math.isfinite(e.value):
            out[p] = (float(e.value), _std(e.std))
    return out


def zoom_range(
    center: float, std: float, truth: float | None, rows: Sequence[ForestRow], param: str
) -> tuple[float, float]:
    """The zoomed panel's range (m): around the recommended value ``center``, wide enough for
    4 of its standard errors, the truth (with a margin) and the determined rows within 5 % of
    the value (so that a near miss between methods is seen), at least ±0.5 % of the value."""
    half = max(4.0 * std, 0.005 * max(abs(center), 0.1))
    if truth is not None and math.isfinite(truth):
        half = max(half, 1.5 * abs(truth - center))
    near = [
        abs(r.value(param) - center) + r.std(param)
        for r in rows
        if r.apart is None and abs(r.value(param) - center) <= 0.05 * max(abs(center), 0.1)
    ]
    if near:
        half = max(half, 1.1 * max(near))
    return (center - half, center + half)


def nice_ticks(lo: float, hi: float, n: int = 3) -> list[float]:
    """About ``n`` round tick values inside [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return []
    raw = (hi - lo) / n
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(s * mag for s in (1.0, 2.0, 2.5, 5.0, 10.0) if s * mag >= raw)
    first = math.ceil(lo / step) * step
    return [round(first + k * step, 12) for k in range(int((hi - first) / step) + 1)]


def _tick_text(v: float, span: float) -> str:
    digits = max(0, min(4, 1 - math.floor(math.log10(max(span, 1e-9) / 3))))
    return f"{v:.{digits}f}"


def _row_layout(rows: Sequence[ForestRow]) -> tuple[list[float], list[tuple[float, str]]]:
    """Canvas y of each row and the (y, text) headers of the set-apart groups (each new
    reason starts with a header line)."""
    ys: list[float] = []
    headers: list[tuple[float, str]] = []
    line = 2
    prev: str | None = None
    for r in rows:
        if r.apart is not None and r.apart != prev:
            headers.append((line * _ROW, f"set apart, {r.apart}:"))
            line += 1
        prev = r.apart
        ys.append(line * _ROW)
        line += 1
    return ys, headers


def canvas_height(rows: Sequence[ForestRow]) -> float:
    """Height (canvas units) of the methods canvas of ``rows`` (titles, rows, group headers,
    tick values, note)."""
    ys, _ = _row_layout(rows)
    return (ys[-1] / _ROW + 5.0) * _ROW if ys else 6 * _ROW


@dataclass(frozen=True)
class _Panel:
    param: str
    x0: float
    x1: float
    lo: float
    hi: float
    title: str

    def x(self, v: float) -> float:
        """Canvas x of value ``v``, clamped to the panel."""
        f = (v - self.lo) / (self.hi - self.lo)
        return self.x0 + (self.x1 - self.x0) * min(max(f, 0.0), 1.0)

    def inside(self, v: float) -> bool:
        return self.lo <= v <= self.hi


def _panels(
    rows: Sequence[ForestRow], truth: dict[str, float], rec: dict[str, tuple[float, float]]
) -> list[_Panel]:
    out = []
    for j, p in enumerate(PARAMS):
        vals = np.array([r.value(p) for r in rows if r.apart is None], dtype=float)
        sds = np.array([r.std(p) for r in rows if r.apart is None], dtype=float)
        extra = [rec[p][0]] if p in rec else []
        full = robust_range(np.concatenate([vals - sds, vals + sds, extra]), truth.get(p))
        (a0, a1), (b0, b1) = _PANELS[2 * j], _PANELS[2 * j + 1]
        out.append(_Panel(p, a0, a1, *full, f"{p} (m)"))
        if p in rec:
            zlo, zhi = zoom_range(rec[p][0], rec[p][1], truth.get(p), rows, p)
            out.append(_Panel(p, b0, b1, zlo, zhi, f"{p} (m) zoomed"))
    return out


def _text(
    rec: rr.RecordingStream,
    path: str,
    xy: list[tuple[float, float]],
    labels: list[str],
    color: tuple[int, int, int],
) -> None:
    """Text at canvas positions: labels of invisible points, shown whatever their number."""
    if not xy:
        return
    rec.log(
        path,
        rr.Points2D(
            np.array(xy, dtype=float),
            labels=labels,
            colors=[color],
            radii=[0.0],
            show_labels=True,
        ),
        static=True,
    )


def _log_canvas(
    rec: rr.RecordingStream, base: str, rows: list[ForestRow], result: AnalysisResult
) -> None:
    """One segment type's canvas under ``base`` (see the module docstring)."""
    truth = {p: float(result.truth[p]) for p in PARAMS if p in result.truth}
    recv = recommended_values(result)
    panels = _panels(rows, truth, recv)
    y_of, headers = _row_layout(rows)
    bottom = y_of[-1] + _ROW
    name_x = sum(_NAMES) / 2
    _text(
        rec,
        f"{base}/names",
        [(name_x, y) for r, y in zip(rows, y_of, strict=True) if r.apart is None],
        [r.label for r in rows if r.apart is None],
        TEXT,
    )
    _text(
        rec,
        f"{base}/names_apart",
        [(name_x, y) for r, y in zip(rows, y_of, strict=True) if r.apart is not None],
        [r.label for r in rows if r.apart is not None],
        GREY_TEXT,
    )
    _text(
        rec,
        f"{base}/headers",
        [(CANVAS_WIDTH / 2, y) for y, _ in headers],
        [h for _, h in headers],
        GREY_TEXT,
    )
    if headers:
        ydiv = headers[0][0] - 0.5 * _ROW
        rec.log(
            f"{base}/divider",
            rr.LineStrips2D(
                [[[0.0, ydiv], [CANVAS_WIDTH, ydiv]]], colors=[GREY], radii=[ui_points(0.5)]
            ),
            static=True,
        )
    _text(
        rec,
        f"{base}/titles",
        [((p.x0 + p.x1) / 2, 0.6 * _ROW) for p in panels],
        [p.title for p in panels],
        TEXT,
    )
    frames: list[list[list[float]]] = []
    bars: list[list[list[float]]] = []
    bars_apart: list[list[list[float]]] = []
    marks: list[tuple[float, float]] = []
    marks_apart: list[tuple[float, float]] = []
    ticks: list[str] = []
    tick_xy: list[tuple[float, float]] = []
    off_xy, off_txt = [], []
    for pan in panels:
        frames.append(
            [
                [pan.x0, 1.4 * _ROW],
                [pan.x0, bottom],
                [pan.x1, bottom],
                [pan.x1, 1.4 * _ROW],
                [pan.x0, 1.4 * _ROW],
            ]
        )
        for v in nice_ticks(pan.lo, pan.hi):
            tick_xy.append((pan.x(v), bottom + 0.8 * _ROW))
            ticks.append(_tick_text(v, pan.hi - pan.lo))
        for r, y in zip(rows, y_of, strict=True):
            v, s = r.value(pan.param), r.std(pan.param)
            if not math.isfinite(v):
                continue
            seg = [[pan.x(v - s), y], [pan.x(v + s), y]]
            (bars_apart if r.apart else bars).append(seg)
            if pan.inside(v):
                (marks_apart if r.apart else marks).append((pan.x(v), y))
            elif r.apart is None and "zoomed" not in pan.title:  # its number at the edge
                off_xy.append((pan.x(v) + (-3.0 if v > pan.hi else 3.0), y))
                off_txt.append(("▶ " if v > pan.hi else "◀ ") + f"{v:.3g}")
    rec.log(
        f"{base}/frames",
        rr.LineStrips2D(frames, colors=[(90, 90, 90)], radii=[ui_points(0.5)]),
        static=True,
    )
    _text(rec, f"{base}/ticks", tick_xy, ticks, TEXT)
    _text(rec, f"{base}/beyond", off_xy, off_txt, TEXT)
    for name, segs, pts, color in (
        ("bars", bars, marks, COLORS["L1"]),
        ("bars_apart", bars_apart, marks_apart, GREY),
    ):
        if segs:
            rec.log(
                f"{base}/{name}",
                rr.LineStrips2D(segs, colors=[color], radii=[ui_points(1.5)]),
                static=True,
            )
        if pts:
            rec.log(
                f"{base}/{name}_value",
                rr.Points2D(np.array(pts), colors=[color], radii=[ui_points(3.0)]),
                static=True,
            )
    lines, colors = [], []
    for pan in panels:
        for src, color in (
            (truth, COLORS["truth"]),
            ({k: v[0] for k, v in recv.items()}, COLORS["psi_estimate"]),
        ):
            at = src.get(pan.param)
            if at is not None and pan.inside(at):
                lines.append([[pan.x(at), 1.4 * _ROW], [pan.x(at), bottom]])
                colors.append(color)
    if lines:
        rec.log(
            f"{base}/lines",
            rr.LineStrips2D(lines, colors=colors, radii=[ui_points(1.0)]),
            static=True,
        )
    note = ["bars: value ± 1 std (spread over repeats; a single fit's standard error)"]
    if truth:
        note.append("grey line: truth")
    if recv and result.estimate is not None:
        note.append(f"green line: recommended ({result.estimate.method})")
    _text(rec, f"{base}/note", [(CANVAS_WIDTH / 2, bottom + 2.0 * _ROW)], ["; ".join(note)], TEXT)


def log_methods(rec: rr.RecordingStream, result: AnalysisResult) -> list[str]:
    """Log one canvas per segment type under ``methods/<segment>/`` and ``methods/table``.

    Returns:
        The segment labels logged, "all" first.
    """
    segs = segment_types(result)
    for seg in segs:
        rows = forest_rows([m for m in result.methods if m.segment == seg])
        if rows:
            _log_canvas(rec, f"{METHODS}/{seg}", rows, result)
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
    lines = [PM_MEANING + "\n"]
    if result.truth:
        lines.append(
            "Truth: " + ", ".join(f"{k} = {v:.4g}" for k, v in result.truth.items()) + "\n"
        )
    lines += [
        "| segment | family | method | L1 (m) | L2 (m) | condition number | repeats | note |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m in result.methods:
        lines.append(
            f"| {m.segment} | {m.family} | {m.name} | {_pm(m.L1, m.L1_std)} | "
            f"{_pm(m.L2, m.L2_std)} | {_pm(m.condition_number, m.condition_number_std)} | "
            f"{m.n_repeats} | {set_apart_reason(m) or ''} |"
        )
    return "\n".join(lines)
