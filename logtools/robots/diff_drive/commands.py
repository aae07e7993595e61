"""The differential drive's commands: ``logcal simulate diff-drive`` and ``logcal reproduce wmr``
(Table 1 of the 1997 mobile-robot paper). Named by the plugin (``simulate``/``reproduce``) and
imported when the CLI is built."""

from __future__ import annotations

import json
import math
import sys
from enum import StrEnum
from pathlib import Path

import typer

from logtools.console import report_console
from logtools.writers.encoding import LogEncoding

__all__ = ["register_reproduce", "register_simulate"]


class DrivePattern(StrEnum):
    """What the simulated robot drives."""

    MIXED = "mixed"
    SQUARE_CW = "square-cw"
    SQUARE_CCW = "square-ccw"


class TrackingLawOption(StrEnum):
    """Tracking law of ``reproduce wmr``."""

    PAPER = "paper"
    CONTROL_POINT = "control-point"


class DriveStyle(StrEnum):
    LOGCAL = "logcal"
    TURTLEBOT = "turtlebot"


def register_simulate(sim: typer.Typer) -> None:
    """Add ``diff-drive`` to the ``simulate`` group."""

    @sim.command("diff-drive")
    def diff_drive(
        out: Path = typer.Option(..., "--out", "-o", help="Output log file."),
        encoding: LogEncoding | None = typer.Option(
            None, "--encoding", help="Log encoding (default: csv for *.csv, else json)."
        ),
        style: DriveStyle = typer.Option(
            DriveStyle.LOGCAL, "--style", help="logcal topics or TurtleBot /joint_states."
        ),
        pattern: DrivePattern = typer.Option(DrivePattern.MIXED, "--pattern", help="Path."),
        radius: float = typer.Option(0.042, "--radius", help="Nominal wheel radius (m), > 0."),
        track: float = typer.Option(0.20, "--track", help="Nominal track width (m), > 0."),
        asymmetry: float = typer.Option(
            0.0, "--asymmetry", help="True r_R/r_L - 1 (e.g. 0.01), mean radius nominal."
        ),
        track_error: float = typer.Option(0.0, "--track-error", help="True b/b_nominal - 1."),
        skid: float = typer.Option(
            1.0, "--skid", help="Effective / geometric track (skid steer, e.g. 1.3), >= 1."
        ),
        slip: float = typer.Option(0.0, "--slip", help="Relative wheel slip std, >= 0."),
        counts: int = typer.Option(
            2797, "--counts", help="Encoder counts per wheel rev (0: none)."
        ),
        pose_noise: float = typer.Option(0.001, "--pose-noise", help="Ground-truth noise (m)."),
        duration: float = typer.Option(120.0, "--duration", help="Mixed driving length (s)."),
        side: float = typer.Option(1.7, "--side", help="Square side (m)."),
        gyro: bool = typer.Option(False, "--gyro", help="Also log a gyro yaw rate (/odom)."),
        conceal: bool = typer.Option(
            False, "--conceal", help="Leave the true parameters out of the metadata."
        ),
        seed: int = typer.Option(0, "--seed", help="Seed (>= 0)."),
    ) -> None:
        """Simulate a differential-drive robot and write its drive log."""
        import numpy as np

        from calib.diff_drive.kinematics import DiffDriveParams
        from calib.diff_drive.sim import (
            SimConfig,
            mixed_commands,
            simulate_diff_drive,
            square_commands,
        )
        from logtools.errors import LogcalInputError
        from logtools.outputs import check_output, write_atomically
        from logtools.writers.diff_drive import run_metadata, write_run

        check_output(out, option="--out", suffixes=(".mcap", ".csv"))
        checks = {
            "--radius": (radius, radius > 0, "> 0 m"),
            "--track": (track, track > 0, "> 0 m"),
            "--asymmetry": (asymmetry, -0.5 < asymmetry < 0.5, "between -0.5 and 0.5"),
            "--track-error": (track_error, -0.5 < track_error < 0.5, "between -0.5 and 0.5"),
            "--skid": (skid, 1.0 <= skid <= 3.0, "between 1 and 3"),
            "--slip": (slip, 0 <= slip < 0.5, "between 0 and 0.5"),
            "--counts": (counts, counts >= 0, ">= 0"),
            "--pose-noise": (pose_noise, pose_noise >= 0, ">= 0 m"),
            "--duration": (duration, duration >= 10, ">= 10 s"),
            "--side": (side, side > 0, "> 0 m"),
            "--seed": (seed, seed >= 0, ">= 0"),
        }
        for opt, (value, ok, expected) in checks.items():
            if not ok or (isinstance(value, float) and not math.isfinite(value)):
                raise LogcalInputError(f"{opt} {value}: expected {expected}")
        nominal = DiffDriveParams(radius, radius, track)
        k = 1 + asymmetry
        true = DiffDriveParams(
            2 * radius * k / (1 + k), 2 * radius / (1 + k), track * (1 + track_error)
        )
        cfg = SimConfig(
            true=true,
            nominal=nominal,
            track_factor=skid,
            slip_std=slip,
            counts_per_rev=counts,
            pose_noise=(pose_noise, pose_noise, pose_noise * 2),
            gyro_noise=0.002 if gyro else 0.0,
        )
        if pattern is DrivePattern.MIXED:
            cmds = mixed_commands(nominal, duration, np.random.default_rng(seed))
        else:
            cmds = square_commands(nominal, side, 1 if pattern is DrivePattern.SQUARE_CCW else -1)
        sim = simulate_diff_drive(cmds, cfg, seed=seed)
        enc = encoding or LogEncoding.for_path(out)
        meta = run_metadata(sim, conceal=conceal, extra={"pattern": str(pattern)})
        n = write_atomically(
            out,
            lambda tmp: write_run(
                tmp,
                sim,
                encoding=enc,
                style=str(style),  # type: ignore[arg-type]
                gyro=gyro,
                metadata=meta,
            ),
        )
        unit = "rows" if enc is LogEncoding.CSV else "messages"
        print(
            f"wrote {out} ({enc}, {style}): {n} {unit}, {sim.t[-1]:.0f} s, r_R = "
            f"{true.r_R * 1e3:.3f} mm, r_L = {true.r_L * 1e3:.3f} mm, track {true.b * 1e3:.1f} mm"
            f" (effective {cfg.effective.b * 1e3:.1f} mm), seed {seed}"
        )


def register_reproduce(group: typer.Typer) -> None:
    """Add ``wmr`` to the ``reproduce`` group."""

    @group.command("wmr")
    def wmr(
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        law: TrackingLawOption = typer.Option(
            TrackingLawOption.PAPER,
            "--law",
            help="Tracking law: the paper's Eqs. 40-44, or the control point ahead of the axle.",
        ),
    ) -> None:
        """Table 1 of the 1997 4-wheeled mobile robot paper: feedback only vs planned path."""
        from rich.table import Table
        from rich.text import Text

        from calib.diff_drive.reproduce import reproduce_wmr

        rep = reproduce_wmr("paper" if law is TrackingLawOption.PAPER else "control_point")
        if as_json:
            sys.stdout.write(json.dumps(rep.to_dict(), indent=1) + "\n")
            return
        table = Table(
            title=f"Table 1 (Kim, Chung, Park 1997) reproduced, {rep.law} law: ours | published"
        )
        for col in ("case", "X error m", "Y error m", "heading conv. s", "position conv. s"):
            table.add_column(col, justify="left" if col == "case" else "right")
        for r in rep.rows:
            p = r.published

            def cell(ours: float, pub: float, fmt: str) -> str:
                o = "never" if math.isinf(ours) else format(ours, fmt)
                return f"{o} | {pub:{fmt}}"

            table.add_row(
                Text(r.name),
                cell(r.x_err, p["x_err"], ".4f"),
                cell(r.y_err, p["y_err"], ".4f"),
                cell(r.t_heading, p["t_heading"], ".1f"),
                cell(r.t_position, p["t_position"], ".1f"),
            )
        console = report_console(min_width=120)
        console.print(table)
        for n in rep.notes:
            console.print(f"• {n}", style="dim", markup=False)
