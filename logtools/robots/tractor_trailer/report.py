"""The tractor-trailer's part of the readable report: segments, the method tables and, when
command-driven discovery also ran, what discovery along the measured path found."""

from __future__ import annotations

import math
from collections.abc import Iterable

from rich.console import RenderableType
from rich.table import Table
from rich.text import Text

from calib.results import AnalysisResult
from calib.results import format_pm as _pm
from calib.tractor_trailer.results import MethodResult
from logtools.safe_text import printable_lines

__all__ = ["CLS_SPLIT_NOTE", "report_lines"]

CLS_SPLIT_NOTE = (
    "CLS (M1-M24) fits the exact model to data the prediction model has forced onto a line: its "
    "split between L1 and L2 comes from the Taylor expansion of sin and cos, not from the robot "
    "(it tends to L1 = (L1+L2)/3 whatever the truth). Read only L1+L2 from those rows."
)


def _cn(value: float) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.4g}"


def _methods_table(rows: Iterable[MethodResult], label: str, truth: dict[str, float]) -> Table:
    table = Table(title=f"Methods on segment type: {label}", title_justify="left", expand=False)
    for col in ("method", "family", "L1 (m)", "L2 (m)", "L1+L2 (m)", "PM slope a (m)", "cond."):
        table.add_column(col, justify="left" if col in ("method", "family") else "right")
    for m in rows:
        total = m.L1 + m.L2 if math.isfinite(m.L1) and math.isfinite(m.L2) else math.nan
        a = m.extra.get("a", math.nan)
        split_style = "dim" if m.family == "CLS" else ""
        table.add_row(
            m.name,
            m.family,
            Text(_pm(m.L1, m.L1_std), style=split_style),
            Text(_pm(m.L2, m.L2_std), style=split_style),
            _pm(total, 0.0),
            _pm(a, m.extra.get("a_std", math.nan)),
            _cn(m.condition_number),
        )
    if truth.get("L1") is not None and truth.get("L2") is not None:
        t1, t2 = float(truth["L1"]), float(truth["L2"])
        table.add_row("truth (from the log)", "", f"{t1:.3f}", f"{t2:.3f}", f"{t1 + t2:.3f}")
    return table


def _segments_table(result: AnalysisResult) -> Table:
    table = Table(title="Segments by curvature command", title_justify="left")
    for col in ("#", "start (s)", "end (s)", "type", "template"):
        table.add_column(col, justify="right" if col != "type" else "left")
    for i, s in enumerate(result.segments, 1):
        params = ", ".join(f"{k}={v:.3g}" for k, v in s.parameters.items())
        table.add_row(str(i), f"{s.start_s:.2f}", f"{s.end_s:.2f}", str(s.command_type), params)
    return table


def report_lines(result: AnalysisResult, per_segment: bool = True) -> list[RenderableType]:
    """The segments table, one method table per command type, and the note on CLS splits."""
    parts: list[RenderableType] = [_segments_table(result)]
    labels = ["all"] + (
        sorted({m.segment for m in result.methods} - {"all"}) if per_segment else []
    )
    truth = {k: v for k, v in result.truth.items() if k in ("L1", "L2")}
    for label in labels:
        rows = [m for m in result.methods if m.segment == label]
        if rows:
            parts.append(_methods_table(rows, label, truth))
    parts.append(Text(CLS_SPLIT_NOTE, style="yellow"))
    path_disc = result.sections.get("path_discovery")
    if path_disc is not None and hasattr(path_disc, "report"):
        parts.append(Text(printable_lines("\n".join(path_disc.report()))))
    return parts
