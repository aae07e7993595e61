"""Readable terminal report of an ``AnalysisResult`` (rich), the answer first: a header, the
recommended estimate, whether the model explains the log (adequacy) and what discovery found;
then the robot plugin's own part (its ``report``: method tables, diagnostics), the stages that
did not run and notes. The same frame for every robot. Text from logs and parameter names are
passed as plain ``Text`` (never markup), so ``Fc[joint1]`` prints as written."""

from __future__ import annotations

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from calib.results import PM_MEANING, AnalysisResult, Estimate
from logtools.adequacy_report import adequacy_text
from logtools.robots import plugin_for
from logtools.safe_text import printable, printable_lines

__all__ = ["print_analysis", "render_analysis"]


def _ci(e: Estimate) -> str:
    if not e.identifiable:
        return f"{e.value:.4g} (not determined)"
    return f"{e.value:.4g} [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]"


def _runs_table(result: AnalysisResult) -> Table:
    names: list[str] = []
    for r in result.runs:
        for name in r.estimate.parameters if r.estimate else ():
            if name not in names:
                names.append(name)
    table = Table(title="Each run on its own (95 % intervals)", title_justify="left")
    units: dict[str, str] = {}
    for r in result.runs:
        for name, e in (r.estimate.parameters.items() if r.estimate else ()):
            units.setdefault(name, e.unit)
    for col in ("run", "estimate", *(f"{n} ({units[n]})" for n in names), "stages not run"):
        table.add_column(Text(printable(col)))
    for r in result.runs:
        skipped = ", ".join(s.stage for s in r.stages if s.status != "ok") or "-"
        params = r.estimate.parameters if r.estimate else {}
        table.add_row(
            Text(printable(r.source.get("path", ""))),
            Text(printable(r.estimate.method if r.estimate else "none")),
            *(Text(_ci(params[n]) if n in params else "-") for n in names),
            Text(printable(skipped)),
        )
    return table


def _answer(result: AnalysisResult, parts: list[RenderableType], title: str) -> None:
    """The recommended estimate and the adequacy verdict: what a person reads first."""
    if result.estimate is not None:
        body = Text(printable_lines(result.estimate.report()))
        body.append("\n  " + PM_MEANING, style="dim")
        parts.append(Panel(body, title=title, expand=False))
    elif result.runs and any(r.estimate is not None for r in result.runs):
        parts.append(Text("No pooled estimate: each run's own estimate is in the table above.",
                          style="yellow"))
    else:
        parts.append(Text("No estimate: no calibration stage could run (see below).",
                          style="bold red"))
    if result.adequacy is not None:
        parts.append(adequacy_text(result.adequacy))


def _tail(result: AnalysisResult, parts: list[RenderableType]) -> None:
    not_ok = [s for s in result.stages if s.status != "ok"]
    if not_ok:
        parts.append(
            Text(
                "Stages that did not run:\n"
                + "\n".join(
                    f"- {s.stage}: {s.status} ({printable(s.reason)})" for s in not_ok
                ),
                style="yellow",
            )
        )
    if result.discovery is not None:
        text = result.discovery.report()
        if not isinstance(text, str):  # a list of lines
            text = "\n".join(text)
        parts.append(Panel(Text(printable_lines(text)), title="Model mismatch", expand=False))
    if result.warnings:
        parts.append(Text("Notes:\n" + "\n".join(f"- {printable(w)}" for w in result.warnings),
                          style="dim"))


def render_analysis(result: AnalysisResult) -> RenderableType:
    """Everything a person reads after ``logcal analyze``, as one rich renderable."""
    if result.runs:
        return _render_pooled(result)
    parts: list[RenderableType] = []
    src = result.source
    head = Text(printable(src.get("path", "")), style="bold")
    head.append(f"  robot: {result.robot}")
    if "duration_s" in src:
        head.append(f"  duration: {src['duration_s']:.1f} s  samples: {src.get('samples', '?')}")
    parts.append(head)
    if src.get("signals"):
        found = ", ".join(f"{k} <- {printable(v)}" for k, v in src["signals"].items())
        parts.append(Text("signals: " + found))
    _answer(result, parts, "Recommended estimate")
    parts += plugin_for(result.robot).report(result)
    _tail(result, parts)
    return Group(*parts)


def _render_pooled(result: AnalysisResult) -> RenderableType:
    parts: list[RenderableType] = [
        Text.assemble(
            (f"{len(result.runs)} runs", "bold"),
            f"  robot: {result.robot}",
            f"  pooled: {result.source['runs_pooled']}" if "runs_pooled" in result.source else "",
        ),
        _runs_table(result),
    ]
    _answer(result, parts, "Recommended estimate (all runs pooled)")
    _tail(result, parts)
    return Group(*parts)


def print_analysis(result: AnalysisResult, console: Console | None = None) -> None:
    """Print ``render_analysis`` to ``console`` (default: stdout)."""
    (console or Console()).print(render_analysis(result))
