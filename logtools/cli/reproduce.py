"""``logcal reproduce patent``: the patent's Figs. 8–13 recomputed beside the published numbers."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable
from typing import TYPE_CHECKING

import typer
from rich.console import Console, Group, RenderableType
from rich.table import Table
from rich.text import Text

if TYPE_CHECKING:
    from calib.tractor_trailer.reproduce import FigureCell, FigureTable, PatentReproduction

__all__ = ["register", "render_reproduction"]

_STATUS_STYLE = {"ok": "green", "outside": "bold red", "round-off": "yellow", "order": "yellow"}
_STATUS_MARK = {"ok": "", "outside": " ✗", "round-off": " ~", "order": " ≈"}


def _fmt_like(value: float, printed: str) -> str:
    """``value`` with the precision of the printed number (same decimals or exponent form)."""
    if value is None or not math.isfinite(value):
        return "-"
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    text = f"{value:.{decimals}e}" if exponent else f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and not text.strip("-0.e+") else text


def _cell_texts(cell: FigureCell) -> tuple[Text, str, str]:
    p = cell.published
    ours = _fmt_like(cell.ours, p.printed)
    pub = p.printed
    if p.sigma is not None:
        ours += "±" + (_fmt_like(cell.ours_std, p.sigma) if math.isfinite(cell.ours_std) else "-")
        pub += "±" + p.sigma
    if p.misprint_of is not None:
        pub += f" (misprint of {p.misprint_of})"
    style = _STATUS_STYLE.get(cell.status, "")
    dev = "-" if not math.isfinite(cell.deviation) else f"{cell.deviation:+.3g}"
    return Text(ours + _STATUS_MARK.get(cell.status, ""), style=style), pub, dev


def _figure_table(fig: FigureTable) -> Table:
    counts = ", ".join(f"{k} {v}" for k, v in sorted(fig.counts().items()))
    table = Table(title=Text(f"Fig. {fig.figure}: {fig.title}  [{counts}]"), title_justify="left")
    amplitudes = sorted({c.published.M for c in fig.cells}, reverse=True)
    for col in ("cmd", "method", "quantity"):
        table.add_column(col)
    for M in amplitudes:
        for col in ("ours", "published", "dev"):
            table.add_column(f"{col} M={M}", justify="right")
    rows: dict[tuple[str, str, str], dict[float, FigureCell]] = {}
    for c in fig.cells:
        p = c.published
        rows.setdefault((p.cmd, p.method, p.quantity), {})[p.M] = c
    for (cmd, method, quantity), by_m in rows.items():
        cells: list[RenderableType] = [Text(cmd), Text(method), Text(quantity)]
        for M in amplitudes:
            cell = by_m.get(M)
            cells += list(_cell_texts(cell)) if cell is not None else ["", "", ""]
        table.add_row(*cells)
    return table


def _split_table(rep: PatentReproduction) -> Table:
    table = Table(title=Text(f"CLS weakness: {rep.split_setting}"), title_justify="left")
    for col in ("true L1", "true L2", "true L1/(L1+L2)", "method", "L1", "L2", "L1/(L1+L2)"):
        table.add_column(col, justify="left" if col == "method" else "right")
    for r in rep.split_rows:
        table.add_row(
            f"{r.L1_true:.3f}",
            f"{r.L2_true:.3f}",
            f"{r.L1_true / (r.L1_true + r.L2_true):.3f}",
            Text(r.method),
            f"{r.L1:.3f}",
            f"{r.L2:.3f}",
            Text(f"{r.split:.3f}", style="yellow"),
        )
    return table


def _notes(lines: Iterable[str]) -> Text:
    return Text("\n".join(f"• {n}" for n in lines), style="dim")


def render_reproduction(rep: PatentReproduction) -> RenderableType:
    """Rich tables of a ``PatentReproduction`` (ours | published | deviation, flags)."""
    parts: list[RenderableType] = [
        Text(
            f"Patent KR 10-1481896, Figs. 8-13 reproduced ({rep.repeats} noisy repeats, "
            f"seed {rep.seed}). ✗ outside the printed precision (ideal) or σ (noisy); "
            "~ round-off-level intercept; ≈ same order of magnitude (Fig. 9).",
            style="bold",
        )
    ]
    for fig in rep.figures:
        parts.append(_figure_table(fig))
        if fig.notes:
            parts.append(_notes(fig.notes))
    parts.append(_split_table(rep))
    parts.append(_notes(rep.notes))
    return Group(*parts)


def register(app: typer.Typer) -> None:
    """Add the ``reproduce`` command group (``reproduce patent``) to ``app``."""
    group = typer.Typer(
        name="reproduce",
        help="Reproduce published results from their own scenario.",
        invoke_without_command=True,
        rich_markup_mode=None,
    )

    @group.callback()
    def _group(ctx: typer.Context) -> None:
        """Reproduce published results from their own scenario."""
        if ctx.invoked_subcommand is None:  # bare ``logcal reproduce``: its help, success
            typer.echo(ctx.get_help())
            raise typer.Exit(0)

    @group.command("patent")
    def patent(
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        repeats: int = typer.Option(10, "--repeats", help="Noisy repeats (patent: 10)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the simulated sensor noise."),
    ) -> None:
        """Recompute the patent's Figs. 8-13 beside the published numbers."""
        from calib.tractor_trailer.reproduce import reproduce_patent
        from logtools.errors import LogcalInputError

        if repeats < 1:
            raise LogcalInputError(f"--repeats {repeats}: expected a whole number >= 1")
        rep = reproduce_patent(repeats=repeats, seed=seed)
        if as_json:
            sys.stdout.write(json.dumps(rep.to_dict(), indent=1) + "\n")
        else:
            Console(width=max(Console().width, 160)).print(render_reproduction(rep))

    from logtools.cli.diff_drive import register_reproduce as _wmr

    _wmr(group)
    @group.command("momentum")
    def momentum(
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        png: str | None = typer.Option(None, "--png", help="Save the trajectories as PNG."),
    ) -> None:
        """JKROS 2012: its constrained estimator vs RLS on the paper's 2-link arm."""
        from calib.manipulator.reproduce import reproduce_momentum, save_png
        from logtools.cli.reproduce_momentum import render_momentum

        rep = reproduce_momentum()
        if png:
            save_png(rep, png)
        if as_json:
            sys.stdout.write(json.dumps(rep.to_dict(), indent=1) + "\n")
        else:
            Console(width=max(Console().width, 160)).print(render_momentum(rep))

    app.add_typer(group, name="reproduce")
