"""The arm's commands: ``logcal simulate manipulator`` (a simulated /joint_states log) and
``logcal reproduce momentum`` (JKROS 2012: its constrained estimator vs RLS on the paper's 2-link
arm). Named by the plugin (``simulate``/``reproduce``) and imported when the CLI is built."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from calib.manipulator.choices import Conceal
from logtools.console import report_console
from logtools.writers.encoding import LogEncoding

if TYPE_CHECKING:
    from calib.manipulator.reproduce import MomentumReproduction

__all__ = ["register_reproduce", "register_simulate", "render_momentum"]


def register_simulate(group: typer.Typer) -> None:
    """Add ``manipulator`` to the ``simulate`` group."""

    @group.command("manipulator")
    def manipulator(
        out: Path = typer.Option(..., "--out", "-o", help="Output log file."),
        encoding: LogEncoding | None = typer.Option(
            None, "--encoding", help="Log encoding (default: csv for *.csv, else json)."
        ),
        arm: str = typer.Option(
            "planar2",
            "--arm",
            help="planar2 (the JKROS 2012 arm) or a URDF path / "
            "example-robot-data name (e.g. panda).",
        ),
        duration: float = typer.Option(20.0, "--duration", help="Run length (s), > 1."),
        rate: float | None = typer.Option(None, "--rate", help="Rate (Hz); default 500 / 1000."),
        seed: int = typer.Option(0, "--seed", help="Seed (>= 0) of the trajectory and noise."),
        torque_noise: float = typer.Option(0.05, "--torque-noise", help="Torque noise std (N·m)."),
        payload: float = typer.Option(0.0, "--payload", help="Held payload (kg), >= 0."),
        conceal: Conceal | None = typer.Option(
            None, "--conceal", help="Leave friction or payload out of the log's declared model."
        ),
    ) -> None:
        """Simulate a serial arm and write its /joint_states log (manipulator)."""
        from logtools.errors import LogcalInputError
        from logtools.outputs import check_output, write_atomically
        from logtools.writers.manipulator import write_simulated_arm

        check_output(out, option="--out", suffixes=(".mcap", ".csv"))
        if duration <= 1 or torque_noise < 0 or payload < 0 or seed < 0:
            raise LogcalInputError(
                f"--duration {duration:g} --torque-noise {torque_noise:g} --payload {payload:g} "
                f"--seed {seed}: expected duration > 1 s and non-negative noise, payload, seed"
            )
        from calib.errors import CalibError

        try:
            run, n = write_atomically(
                out,
                lambda tmp: write_simulated_arm(
                    tmp,
                    arm=arm,
                    encoding=encoding or LogEncoding.for_path(out),
                    duration_s=duration,
                    rate_hz=rate,
                    seed=seed,
                    torque_noise=torque_noise,
                    payload=payload,
                    conceal=conceal,
                ),
            )
        except CalibError as err:
            raise LogcalInputError(f"--arm {arm}: {err}") from err
        print(
            f"wrote {out}: {n} messages, {len(run.joint_names)} joints, {duration:g} s, seed {seed}"
        )


def register_reproduce(group: typer.Typer) -> None:
    """Add ``momentum`` to the ``reproduce`` group."""

    @group.command("momentum")
    def momentum(
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        png: str | None = typer.Option(None, "--png", help="Save the trajectories as PNG."),
    ) -> None:
        """JKROS 2012: its constrained estimator vs RLS on the paper's 2-link arm."""
        from calib.manipulator.reproduce import reproduce_momentum, save_png

        rep = reproduce_momentum()
        if png:
            save_png(rep, png)
        if as_json:
            sys.stdout.write(json.dumps(rep.to_dict(), indent=1) + "\n")
        else:
            report_console(min_width=160).print(render_momentum(rep))


def _s(x: float) -> str:
    return "never" if not math.isfinite(x) else f"{x:.3f}"


def render_momentum(rep: MomentumReproduction) -> RenderableType:
    """Per base parameter: truth, final values, convergence time (5 %) and early jumps."""
    from calib.manipulator.reproduce import PAPER_STATES

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
