"""Readable terminal report of an ``AnalysisResult`` (rich tables)."""

from __future__ import annotations

import math
from collections.abc import Iterable

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from calib.results import AnalysisResult, MethodResult

__all__ = ["CLS_SPLIT_NOTE", "print_analysis", "render_analysis"]

CLS_SPLIT_NOTE = (
    "CLS (M1-M24) fits the exact model to data the prediction model has forced onto a line: its "
    "split between L1 and L2 comes from the Taylor expansion of sin and cos, not from the robot "
    "(it tends to L1 = (L1+L2)/3 whatever the truth). Read only L1+L2 from those rows."
)


PM_MEANING = "(+/- is one standard error; [95 %: lo, hi] the 95 % interval.)"


def _pm(value: float, std: float, digits: int = 3) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    if std is None or not math.isfinite(std) or std == 0:
        return f"{value:.{digits}f}"
    return f"{value:.{digits}f} ± {std:.{digits}f}"


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


def _ci(result: AnalysisResult, name: str) -> str:
    est = result.estimate
    if est is None:
        return "-"
    e = est.parameters[name]
    if not e.identifiable:
        return f"{e.value:.3f} (not determined)"
    return f"{e.value:.3f} [{e.ci95[0]:.3f}, {e.ci95[1]:.3f}]"


def _runs_table(result: AnalysisResult) -> Table:
    table = Table(title="Each run on its own (95 % intervals)", title_justify="left")
    for col in ("run", "estimate", "L1 (m)", "L2 (m)", "stages not run"):
        table.add_column(col)
    for r in result.runs:
        skipped = ", ".join(s.stage for s in r.stages if s.status != "ok") or "-"
        table.add_row(
            str(r.source.get("path", "")),
            r.estimate.method if r.estimate else "none",
            _ci(r, "L1"),
            _ci(r, "L2"),
            skipped,
        )
    return table


def render_analysis(result: AnalysisResult, *, per_segment: bool = True) -> RenderableType:
    """Everything a person reads after ``logcal analyze``, as one rich renderable."""
    if result.runs:
        return _render_pooled(result)
    parts: list[RenderableType] = []
    src = result.source
    head = f"[bold]{src.get('path', '')}[/bold]  robot: {result.robot}"
    if "duration_s" in src:
        head += f"  duration: {src['duration_s']:.1f} s  samples: {src.get('samples', '?')}"
    parts.append(Text.from_markup(head))
    if src.get("signals"):
        found = ", ".join(f"{k} <- {v}" for k, v in src["signals"].items())
        parts.append(Text("signals: " + found))
    parts.append(_segments_table(result))
    labels = ["all"] + (
        sorted({m.segment for m in result.methods} - {"all"}) if per_segment else []
    )
    truth = {k: v for k, v in result.truth.items() if k in ("L1", "L2")}
    for label in labels:
        rows = [m for m in result.methods if m.segment == label]
        if rows:
            parts.append(_methods_table(rows, label, truth))
    parts.append(Text(CLS_SPLIT_NOTE, style="yellow"))
    if result.estimate is not None:
        parts.append(
            Panel(result.estimate.report() + "\n  " + PM_MEANING, title="Recommended estimate",
                  expand=False)
        )
    else:
        parts.append(Text("No link-length estimate: no calibration stage could run (see below).",
                          style="bold red"))
    not_ok = [s for s in result.stages if s.status != "ok"]
    if not_ok:
        parts.append(
            Text(
                "Stages that did not run:\n"
                + "\n".join(f"- {s.stage}: {s.status} ({s.reason})" for s in not_ok),
                style="yellow",
            )
        )
    if result.discovery is not None:
        parts.append(Panel(result.discovery.report(), title="Model mismatch", expand=False))
    if result.warnings:
        parts.append(Text("Notes:\n" + "\n".join(f"- {w}" for w in result.warnings), style="dim"))
    return Group(*parts)


def _render_pooled(result: AnalysisResult) -> RenderableType:
    parts: list[RenderableType] = [
        Text.from_markup(
            f"[bold]{len(result.runs)} runs[/bold]  robot: {result.robot}  pooled: "
            f"{result.source.get('runs_pooled', 0)}"
        ),
        _runs_table(result),
    ]
    if result.estimate is not None:
        parts.append(
            Panel(result.estimate.report() + "\n  " + PM_MEANING,
                  title="Recommended estimate (all runs pooled)", expand=False)
        )
    else:
        parts.append(Text("No pooled estimate.", style="bold red"))
    not_ok = [s for s in result.stages if s.status != "ok"]
    if not_ok:
        parts.append(Text("\n".join(f"- {s.stage}: {s.status} ({s.reason})" for s in not_ok),
                          style="yellow"))
    if result.warnings:
        parts.append(Text("Notes:\n" + "\n".join(f"- {w}" for w in result.warnings), style="dim"))
    return Group(*parts)


def print_analysis(result: AnalysisResult, console: Console | None = None) -> None:
    """Print ``render_analysis`` to ``console`` (default: stdout)."""
    (console or Console()).print(render_analysis(result))
