"""``logcal analyze LOG``: calibrate, report with uncertainty, discover model mismatch."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer
from rich.console import Console

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` command to ``app``."""

    @app.command("analyze")
    def analyze(
        log: Path = typer.Argument(..., help="Drive log: MCAP (.mcap) or CSV (.csv)."),
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        rrd: Path | None = typer.Option(None, "--rrd", help="Save a rerun recording here."),
        png: Path | None = typer.Option(
            None, "--png", help="Save a static PNG of the main views (default: beside --rrd)."
        ),
        repeats: int = typer.Option(10, "--repeats", min=1, help="Bootstrap repeats per method."),
        baseline: str = typer.Option(
            "steady", "--baseline", help="Discovery baseline: steady (patent) or transient."
        ),
        channel_map: Path | None = typer.Option(
            None, "--channel-map", help="TOML mapping topics/fields to logical signals."
        ),
        no_discovery: bool = typer.Option(False, "--no-discovery", help="Skip discovery."),
        seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap draws."),
    ) -> None:
        """Calibrate the robot's parameters from LOG and explain model mismatch."""
        from logtools.analyze import AnalysisConfig, analyze_log
        from logtools.channel_map import load_channel_map
        from logtools.errors import LogcalInputError
        from logtools.report import print_analysis

        if baseline not in ("steady", "transient"):
            raise LogcalInputError(
                f"--baseline {baseline!r}: expected 'steady' (the patent's steady-state model) "
                "or 'transient' (off-axle trailer kinematics)."
            )
        cmap = load_channel_map(channel_map) if channel_map else None
        cfg = AnalysisConfig(
            repeats=repeats, baseline=baseline, seed=seed, discovery=not no_discovery
        )
        err = Console(stderr=True)
        show = sys.stderr.isatty()
        if show:
            with err.status("analysing", spinner="dots") as status:
                loaded, result = analyze_log(
                    log, channel_map=cmap, config=cfg, progress=lambda s: status.update(s)
                )
        else:
            loaded, result = analyze_log(log, channel_map=cmap, config=cfg)
        if rrd is not None or png is not None:
            from viz.plots import write_report_png
            from viz.recording import write_recording

            if rrd is not None:
                write_recording(rrd, loaded.frame, result)
                err.print(f"rerun recording saved: {rrd}")
            png_path = png or (rrd.with_suffix(".png") if rrd is not None else None)
            if png_path is not None:
                write_report_png(png_path, loaded.frame, result)
                err.print(f"report image saved: {png_path}")
        if as_json:
            sys.stdout.write(json.dumps(result.to_dict(), indent=2) + "\n")
        else:
            print_analysis(result)
