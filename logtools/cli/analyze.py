"""``logcal analyze LOG``: calibrate, report with uncertainty, discover model mismatch."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from calib.results import Baseline

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` command to ``app``."""

    @app.command("analyze")
    def analyze(
        logs: list[Path] = typer.Argument(
            ...,
            help="Drive logs: MCAP, CSV, ROS bags (rosbag2 folder or .bag), or folders of them. "
            "Several runs of one robot are also pooled into one estimate.",
        ),
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        rrd: Path | None = typer.Option(None, "--rrd", help="Save a rerun recording here."),
        png: Path | None = typer.Option(
            None, "--png", help="Save a static PNG of the main views (default: beside --rrd)."
        ),
        repeats: int = typer.Option(10, "--repeats", min=1, help="Bootstrap repeats per method."),
        baseline: Baseline = typer.Option(
            Baseline.TRANSIENT, "--baseline",
            help="Discovery baseline of the tractor-trailer: transient (default) or steady "
            "(the patent's view).",
        ),
        urdf: str | None = typer.Option(
            None, "--urdf",
            help="An arm's URDF file, or a model name of example-robot-data (e.g. panda).",
        ),
        cutoff_hz: float | None = typer.Option(
            None, "--cutoff-hz",
            help="An arm's zero-phase low-pass cut-off for q, q', q'' and torque (Hz; default 10).",
        ),
        channel_map: Path | None = typer.Option(
            None, "--channel-map", help="TOML mapping topics/fields to logical signals."
        ),
        no_discovery: bool = typer.Option(False, "--no-discovery", help="Skip discovery."),
        discovery_span: float | None = typer.Option(
            None, "--discovery-span", min=0.0,
            help="Seconds of a long tractor-trailer log discovery looks at, in windows spread "
            "over it (default 600; 0: all of it, slower).",
        ),
        seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap draws."),
    ) -> None:
        """Calibrate the robot's parameters from LOG(s) and explain model mismatch."""
        from logtools.analyze import AnalysisConfig, analyze_logs
        from logtools.channel_map import load_channel_map
        from logtools.outputs import check_output, write_atomically
        from logtools.report import print_analysis
        from logtools.robots import plugin_for
        from logtools.robots.base import load_view
        from logtools.runs import expand_runs
        from logtools.safe_text import printable

        runs = expand_runs(logs)
        inputs = [Path(r) for r in runs] + list(logs)
        if rrd is not None:
            check_output(rrd, option="--rrd", suffixes=(".rrd",), inputs=inputs)
        if png is not None:
            check_output(png, option="--png", suffixes=(".png",), inputs=inputs)
        cmap = load_channel_map(channel_map) if channel_map else None
        cfg = AnalysisConfig(
            repeats=repeats, baseline=baseline, seed=seed, discovery=not no_discovery,
            debug=_debug(),
            extra=({"urdf": urdf} if urdf else {})
            | ({"cutoff_hz": cutoff_hz} if cutoff_hz is not None else {})
            | ({"discovery_span_s": discovery_span} if discovery_span is not None else {}),
        )
        err = Console(stderr=True)
        from calib.models.hitch_rk4 import compiled_available

        if not compiled_available():
            err.print(
                "logcal: the compiled integrator (calib/models/_hitch_rk4.c) is not built here; "
                "analysing on its numpy loop, about 5x slower (pip install . builds it)",
                markup=False,
            )
        if sys.stderr.isatty():
            with err.status("analysing", spinner="dots") as status:
                loadeds, result = analyze_logs(
                    runs, channel_map=cmap, config=cfg, progress=lambda s: status.update(s)
                )
        else:
            loadeds, result = analyze_logs(runs, channel_map=cmap, config=cfg)
        if rrd is not None or png is not None:
            plugin = plugin_for(result.robot)
            per_run = result.runs or [result]
            png_path = png or (rrd.with_suffix(".png") if rrd is not None else None)
            for i, (loaded, res) in enumerate(zip(loadeds, per_run, strict=True)):
                tag = "" if len(per_run) == 1 else f"_run{i + 1}"
                for target, view, what, option in (
                    (rrd, plugin.views, "rerun recording", "--rrd"),
                    (png_path, plugin.png, "report image", "--png"),
                ):
                    if target is None:
                        continue
                    if view is None:
                        err.print(f"logcal: the {plugin.title} has no {what} yet; not written",
                                  markup=False)
                        continue
                    out = check_output(
                        target.with_name(target.stem + tag + target.suffix), option=option,
                        suffixes=(target.suffix.lower(),), inputs=inputs,
                    )
                    draw = load_view(view)

                    def write(tmp: Path, d: Any = draw, lo: Any = loaded, r: Any = res) -> Path:
                        return d(tmp, lo, r)

                    write_atomically(out, write)
                    err.print(f"{what} saved: {printable(out)}", markup=False, highlight=False)
        if as_json:
            sys.stdout.write(json.dumps(result.to_dict(), indent=2) + "\n")
        else:
            print_analysis(result)
        bad = result.source.get("errors") or []
        if bad:
            for message in bad:
                err.print(f"logcal: error: {printable(message)}", markup=False,
                          highlight=False)
            raise typer.Exit(2)


def _debug() -> bool:
    from logtools.cli.main import debug_enabled

    return debug_enabled()
