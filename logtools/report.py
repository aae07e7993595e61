"""Readable terminal report of an ``AnalysisResult`` (rich), the answer first: a header, the
recommended estimate, whether the model explains the log (adequacy) and what discovery found;
then the robot plugin's own part (its ``report``: method tables, diagnostics), the stages that
did not run and notes. The same frame for every robot. Text from logs and parameter names are
passed as plain ``Text`` (never markup), so ``Fc[joint1]`` prints as written."""

from __future__ import annotations

import math
from typing import Any

from rich.console import Console, Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from calib.results import PM_MEANING, AnalysisResult, Estimate
from logtools.adequacy_report import adequacy_text
from logtools.robots import plugin_for
from logtools.runs import short_names
from logtools.safe_text import printable, printable_lines

__all__ = ["DETAILS", "print_analysis", "render_analysis"]

DETAILS = ("quiet", "answer", "methods")
"""How much a report shows: the answer alone; the answer, what the robot's summary holds,
stages and notes (the default); all of that and every method table and diagnostic."""


def _ci(e: Estimate) -> str:
    if not e.identifiable:
        return f"{e.value:.4g} *"
    return f"{e.value:.4g} [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]"


def _cell(e: Estimate, one_line: bool = False) -> str:
    if not math.isfinite(e.value):
        return "- *"  # no value (not determined; the report says the range the data allow)
    if not e.identifiable:
        return f"{e.value:.4g} *"
    gap = " " if one_line else "\n"
    return f"{e.value:.4g}{gap}[{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]"


def _runs_table(result: AnalysisResult, one_line: bool = False) -> Table:
    """Each run's own estimate (``one_line``: a run's row on one line, an interval beside its
    value): runs by their shortest unique names, values whole (an interval
    on its own line), the method in the title when every run used the same one, the stages
    that did not run as footnotes."""
    names: list[str] = []
    units: dict[str, str] = {}
    for r in result.runs:
        for name, e in r.estimate.parameters.items() if r.estimate else ():
            if name not in names:
                names.append(name)
            units.setdefault(name, e.unit)
    methods = {r.estimate.method if r.estimate else "none" for r in result.runs}
    one_method = len(methods) == 1
    piece = "window" if "windows" in result.source else "run"
    title = f"Each {piece} on its own (95 % intervals" + (
        f"; {printable(next(iter(methods)))})" if one_method else ")"
    )
    table = Table(title=Text(title), title_justify="left")
    table.add_column(piece, no_wrap=True)
    if not one_method:
        table.add_column("estimate", overflow="fold")
    for n in names:
        table.add_column(Text(printable(f"{n} ({units[n]})")), overflow="fold")
    notes: list[str] = []
    runs = short_names([str(r.source.get("path", "")) for r in result.runs])
    if "windows" in result.source:  # one log analysed by time windows: windows by their span
        from logtools.windows import window_label

        runs = [window_label(r) for r in result.runs]
    for r, run_name in zip(result.runs, runs, strict=True):
        params = r.estimate.parameters if r.estimate else {}
        skipped = [s.stage for s in r.stages if s.status != "ok"]
        if skipped:
            notes.append(f"{run_name}: stages not run: {', '.join(skipped)}")
        table.add_row(
            Text(printable(run_name)),
            *([] if one_method else [Text(printable(r.estimate.method if r.estimate else "none"))]),
            *(Text(_cell(params[n], one_line) if n in params else "-") for n in names),
        )
    caption = ["* not determined (the run's own report says why)"]
    table.caption = Text("\n".join(printable(x) for x in caption + notes))
    table.caption_justify = "left"
    return table


SHORT_DISCOVERY = 8
"""Lines of the discovery engines' own details shown without ``--methods`` (the findings
themselves, :meth:`~calib.discovery.report.DiscoveryReport.answer_lines`, are never cut)."""


def _discovery_lines(discovery: Any, detail: str) -> list[str]:
    """The "Model mismatch" panel's lines: the findings whole (effects with their values, the
    verdict before -> after), then the engines' details, cut to ``SHORT_DISCOVERY`` lines
    unless ``detail`` is "methods" and left out when it is "quiet"."""
    answer_lines = getattr(discovery, "answer_lines", None)
    if answer_lines is not None:
        head, rest = list(answer_lines()), [str(x) for x in getattr(discovery, "more", ())]
    else:  # any other result: its report, which may be cut as a whole
        text = discovery.report()
        head, rest = [], (text.split("\n") if isinstance(text, str) else list(text))
    if detail == "quiet":
        return head or rest[:SHORT_DISCOVERY]
    if detail != "methods" and len(rest) > SHORT_DISCOVERY:
        rest = [*rest[:SHORT_DISCOVERY], "... (the engines' details: --methods)"]
    return head + rest


def _answer(result: AnalysisResult, parts: list[RenderableType], title: str, detail: str) -> None:
    """What a person reads first: the recommended estimate, the adequacy verdict and what
    discovery found (named and described effects, the verdict before -> after)."""
    if result.estimate is not None:
        body = Text(printable_lines(result.estimate.report()))
        body.append("\n  " + PM_MEANING, style="dim")
        parts.append(Panel(body, title=title, expand=False))
    elif result.runs and any(r.estimate is not None for r in result.runs):
        parts.append(
            Text(
                "No pooled estimate: each run's own estimate is in the table above.", style="yellow"
            )
        )
    else:
        parts.append(
            Text("No estimate: no calibration stage could run (see below).", style="bold red")
        )
    if result.adequacy is not None:
        parts.append(adequacy_text(result.adequacy))
    if result.discovery is not None:
        text = "\n".join(_discovery_lines(result.discovery, detail))
        parts.append(Panel(Text(printable_lines(text)), title="Model mismatch", expand=False))


def _tail(result: AnalysisResult, parts: list[RenderableType]) -> None:
    not_ok = [s for s in result.stages if s.status != "ok"]
    if not_ok:
        parts.append(
            Text(
                "Stages that did not run:\n"
                + "\n".join(f"- {s.stage}: {s.status} ({printable(s.reason)})" for s in not_ok),
                style="yellow",
            )
        )
    if result.warnings:
        parts.append(
            Text("Notes:\n" + "\n".join(f"- {printable(w)}" for w in result.warnings), style="dim")
        )


def render_analysis(
    result: AnalysisResult, detail: str = "methods", one_line: bool = False
) -> RenderableType:
    """What a person reads after ``logcal analyze``, as one rich renderable; ``detail`` one of
    ``DETAILS``; ``one_line``: each run's row of a table on one line (a file or a pipe)."""
    if result.runs:
        return _render_pooled(result, detail, one_line)
    parts: list[RenderableType] = []
    src = result.source
    head = Text(printable(src.get("path", "")), style="bold")
    head.append(f"  robot: {result.robot}")
    if "duration_s" in src:
        head.append(f"  duration: {src['duration_s']:.1f} s  samples: {src.get('samples', '?')}")
    parts.append(head)
    if src.get("signals") and detail != "quiet":
        found = ", ".join(f"{k} <- {printable(v)}" for k, v in src["signals"].items())
        parts.append(Text("signals: " + found))
    _answer(result, parts, "Recommended estimate", detail)
    if detail == "quiet":
        return Group(*parts)
    plugin = plugin_for(result.robot)
    if plugin.summary is not None:
        parts += plugin.summary(result)
    if detail == "methods":
        parts += plugin.report(result)
    _tail(result, parts)
    if detail == "answer":
        parts.append(Text("(every method's table: --methods)", style="dim"))
    return Group(*parts)


def _render_pooled(result: AnalysisResult, detail: str, one_line: bool) -> RenderableType:
    windows = result.source.get("windows")
    parts: list[RenderableType] = [
        Text.assemble(
            (
                f"{printable(str(result.source.get('path', '')))}: {len(result.runs)} windows of "
                f"{windows['window_s']:g} s"
                if isinstance(windows, dict)
                else f"{len(result.runs)} runs",
                "bold",
            ),
            f"  robot: {result.robot}",
            f"  pooled: {result.source['runs_pooled']}" if "runs_pooled" in result.source else "",
        ),
        _runs_table(result, one_line),
    ]
    _answer(
        result,
        parts,
        "Recommended estimate (all windows pooled)"
        if windows
        else "Recommended estimate (all runs pooled)",
        detail,
    )
    if detail == "quiet":
        return Group(*parts)
    plugin = plugin_for(result.robot)
    if plugin.pooled_summary is not None:
        parts += plugin.pooled_summary(result)
    _tail(result, parts)
    return Group(*parts)


def print_analysis(
    result: AnalysisResult, console: Console | None = None, detail: str = "methods"
) -> None:
    """Print ``render_analysis`` to ``console`` (default: stdout), no NaN shown as a number
    (:func:`~logtools.safe_text.no_nan`)."""
    from logtools.console import report_console
    from logtools.safe_text import no_nan

    console = console or report_console()
    with console.capture() as captured:
        console.print(render_analysis(result, detail, one_line=not console.is_terminal))
    console.file.write(no_nan(captured.get()))
    console.file.flush()
