"""The table of ``logcal reproduce momentum`` (JKROS 2012 estimator vs RLS)."""

from __future__ import annotations

import math

from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from calib.manipulator.reproduce import PAPER_STATES, MomentumReproduction

__all__ = ["render_momentum"]


def _s(x: float) -> str:
    return "never" if not math.isfinite(x) else f"{x:.3f}"


def render_momentum(rep: MomentumReproduction) -> RenderableType:
    """Per base parameter: truth, final values, convergence time (5 %) and early jumps."""
    ests = list(rep.trajectories)
    table = Table(
        title="JKROS 2012 reproduced: convergence to within 5 % (s), jumps > 10 %",
        title_justify="left",
    )
    table.add_column("parameter")
    table.add_column("truth", justify="right")
    short = {
        "paper-constrained": "paper",
        "RLS": "RLS",
        "paper-constrained on base parameters": "paper, base",
    }
    for e in ests:
        tag = short.get(e, e)
        table.add_column(Text(f"{tag} final"), justify="right")
        table.add_column(Text(f"{tag} conv. (s)"), justify="right")
        table.add_column(Text(f"{tag} jumps (last s)"), justify="right")
    for r in rep.rows:
        cells: list[RenderableType] = [Text(r.name), f"{r.truth:.4g}"]
        for e in ests:
            last = "" if not math.isfinite(r.last_jump_s[e]) else f" ({r.last_jump_s[e]:.2f})"
            cells += [f"{r.final[e]:.4g}", _s(r.converged_s[e]), f"{r.jumps[e]}{last}"]
        table.add_row(*cells)
    summ = rep.summary()
    lines = [
        f"{e}: median {_s(summ[f'{e}_median_s'])} s, slowest {_s(summ[f'{e}_max_s'])} s"
        for e in ests
    ]
    return Group(
        Text(
            "Columns: paper = the paper's estimator on its ten parameters; paper, base = the "
            "same on the nine base parameters; RLS = RLS on the ten (P0 = 1000 I)."
        ),
        table,
        Text("Paper states: " + PAPER_STATES, style="bold"),
        Text("Ours: " + "; ".join(lines)),
        Text("\n".join(f"• {n}" for n in rep.notes), style="dim"),
    )
