"""``logcal analyze LOG``: calibrate, report with uncertainty, discover model mismatch."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.text import Text

from logtools.cli._inputs import (
    LOGS_HELP,
    channel_map_option,
    end_option,
    ground_truth_option,
    logs_argument,
    signal_option,
    start_option,
    t_max_diff_option,
    t_offset_option,
)
from logtools.cli._robot_options import GivenOptions, with_robot_options
from logtools.errors import LogcalInputError

if TYPE_CHECKING:
    from logtools.views import WrittenViews

_LOGS = logs_argument(
    LOGS_HELP + " Several runs of one robot are also pooled into one estimate; files holding the "
    "same recording are counted once."
)
_CHANNEL_MAP = channel_map_option()
_SIGNAL = signal_option()
_GROUND_TRUTH = ground_truth_option()

__all__ = ["register", "say_written"]


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` command to ``app``."""

    @app.command("analyze")
    @with_robot_options("analyze")
    def analyze(
        logs: list[Path] = _LOGS,
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        rrd: Path | None = typer.Option(
            None,
            "--rrd",
            metavar="FILE.rrd",
            help="Save a rerun recording here (several runs: one file holding every run).",
        ),
        png: Path | None = typer.Option(
            None,
            "--png",
            metavar="FILE.png",
            help="Save a static PNG of the main views (default: beside --rrd; one run only).",
        ),
        repeats: int = typer.Option(
            10, "--repeats", min=1, metavar="N", help="Bootstrap repeats per method."
        ),
        channel_map: Path | None = _CHANNEL_MAP,
        signal: list[str] | None = _SIGNAL,
        ground_truth: Path | None = _GROUND_TRUTH,
        t_offset: str | None = t_offset_option(),
        t_max_diff: float | None = t_max_diff_option(),
        start: float | None = start_option(),
        end: float | None = end_option(),
        window: float | None = typer.Option(
            None,
            "--window",
            metavar="SECONDS",
            help="Analyse the log by time windows of this length, each read and analysed on "
            "its own, and pool them (memory stays that of one window); 0: the whole log at "
            "once. Default: windows of 1 h at 100 Hz when the log holds more than 2 h of "
            "samples at 100 Hz (an MCAP file with a summary), else whole.",
        ),
        no_discovery: bool = typer.Option(False, "--no-discovery", help="Skip discovery."),
        seed: int = typer.Option(0, "--seed", metavar="N", help="Seed of the bootstrap draws."),
        methods: bool = typer.Option(
            False,
            "--methods",
            "-v",
            help="Also print every method's table and the robot's diagnostics (the report "
            "opens with the answer either way).",
        ),
        quiet: bool = typer.Option(
            False,
            "--quiet",
            "-q",
            help="Print only the answer: the recommended estimate and whether the model "
            "explains the log.",
        ),
        *,
        robot_options: GivenOptions,
    ) -> None:
        """Calibrate the robot's parameters from LOG(s) and explain model mismatch."""
        from logtools.analyze import AnalysisConfig, analyze_logs
        from logtools.cli._inputs import read_inputs, say
        from logtools.cli._robot_options import general_warnings
        from logtools.outputs import check_output
        from logtools.report import print_analysis
        from logtools.robots import plugin_for
        from logtools.safe_text import printable
        from logtools.views import write_views
        from logtools.windows import check_window

        check_window(window)
        if window and (rrd is not None or png is not None):
            raise LogcalInputError(
                f"--window {window:g}: the views (--rrd, --png) draw every sample of the log; "
                "give --window 0, or --start/--end to view a part"
            )
        inputs = read_inputs(
            logs,
            channel_map=channel_map,
            signals=signal,
            ground_truth=ground_truth,
            t_offset=t_offset,
            t_max_diff=t_max_diff,
            start=start,
            end=end,
        )
        runs = inputs.runs
        every = [Path(r) for r in runs] + [g for s in inputs.same for g in s.same] + list(logs)
        if rrd is not None:
            check_output(rrd, option="--rrd", suffixes=(".rrd",), inputs=every)
        if png is not None:
            check_output(png, option="--png", suffixes=(".png",), inputs=every)
            if len(runs) > 1:
                raise LogcalInputError(
                    f"--png {png}: a report image shows one run and {len(runs)} runs were given; "
                    "give one log, or use --rrd (one recording file holds every run)"
                )
        cfg = AnalysisConfig(
            repeats=repeats,
            seed=seed,
            discovery=not no_discovery,
            debug=_debug(),
            robot_options=robot_options.by_robot(),
            # the views need every sample: with --rrd/--png the log is analysed whole
            window_s=0.0 if rrd is not None or png is not None else window,
        )
        err = Console(stderr=True)
        if sys.stderr.isatty():
            with err.status("analysing", spinner="dots") as status:
                loadeds, result = analyze_logs(
                    runs,
                    channel_map=inputs.channel_map,
                    config=cfg,
                    progress=lambda s: status.update(Text(s)),
                )
        else:
            loadeds, result = analyze_logs(runs, channel_map=inputs.channel_map, config=cfg)
        plugin = plugin_for(str(result.robot))
        unused = robot_options.unused(plugin) + general_warnings(
            plugin,
            {
                "--ground-truth": ("pose", ground_truth),
            },
        )
        for warning in unused:
            say(f"logcal: warning: {warning}")
        if inputs.same or unused:
            result = replace(
                result,
                warnings=[*inputs.notes, *unused, *result.warnings],
                source={
                    **result.source,
                    "same_recordings": [
                        {
                            "kept": str(g.kept),
                            "same": [str(p) for p in g.same],
                            "evidence": g.evidence,
                        }
                        for g in inputs.same
                    ],
                },
            )
        if rrd is not None or png is not None:
            say_written(
                write_views(
                    loadeds,
                    result,
                    rrd=rrd,
                    png=png,
                    inputs=every,
                    implicit_png=png is None,
                    config=cfg,
                )
            )
        if as_json:
            sys.stdout.write(json.dumps(result.to_dict(), indent=2) + "\n")
        else:
            print_analysis(result, detail="quiet" if quiet else "methods" if methods else "answer")
        bad = result.source.get("errors") or []
        if bad:
            for message in bad:
                err.print(f"logcal: error: {printable(message)}", markup=False, highlight=False)
            raise typer.Exit(2)


def say_written(written: WrittenViews) -> None:
    """Say on stderr what :func:`logtools.views.write_views` wrote, and what not and why."""
    from logtools.cli._inputs import say

    for kind, text in written.messages:
        say(text if kind == "saved" else f"logcal: {text}")


def _debug() -> bool:
    from logtools.cli.state import debug_enabled

    return debug_enabled()
